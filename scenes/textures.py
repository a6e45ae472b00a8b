"""Procedural textures for the worlds, made with numpy and encoded as PNG assets.

Each function returns an ``(H, W, 3) uint8`` image; randomness comes only from the
``numpy.random.Generator`` passed in, so a world's textures are deterministic for its seed.
Patterns are vectorised (no loops over pixels); a few short loops run over bricks or planks.
"""

from __future__ import annotations

import cv2
import numpy as np

TEXTURE_SIZE = 256  # pixels per side; textures repeat per metre via MuJoCo's texrepeat


def _as_rgb(colour) -> np.ndarray:
    return np.asarray(colour, dtype=np.float64).reshape(1, 1, 3)


def fractal_noise(
    rng: np.random.Generator, size: int = TEXTURE_SIZE, base: int = 4, octaves: int = 4
) -> np.ndarray:
    """Return tileable-looking value noise in [0, 1]: random grids upsampled and summed by octave.

    Parameters
    ----------
    rng : numpy.random.Generator
        The generator of the pattern's randomness.
    size : int, default TEXTURE_SIZE
        Side of the square image, pixels.
    base : int, default 4
        Cells per side of the coarsest grid.
    octaves : int, default 4
        Number of grids, each twice as fine and half as strong as the one before.

    Returns
    -------
    ndarray of shape (size, size), float
        The noise.
    """
    out = np.zeros((size, size))
    amplitude, total = 1.0, 0.0
    for octave in range(octaves):
        cells = base * 2**octave
        grid = rng.random((cells, cells))
        out += amplitude * cv2.resize(grid, (size, size), interpolation=cv2.INTER_CUBIC)
        total += amplitude
        amplitude *= 0.5
    out /= total
    return np.clip((out - out.min()) / max(np.ptp(out), 1e-9), 0.0, 1.0)


def _finish(img: np.ndarray) -> np.ndarray:
    return np.clip(np.rint(img * 255.0), 0, 255).astype(np.uint8)


def painted(rng: np.random.Generator, colour, grain: float = 0.06) -> np.ndarray:
    """Paint plaster: a flat colour with low-frequency mottling and fine grain.

    Parameters
    ----------
    rng : numpy.random.Generator
        The generator of the pattern's randomness.
    colour : sequence of float
        The base colour, RGB in 0..1.
    grain : float, default 0.06
        Relative strength of the mottling and grain.

    Returns
    -------
    ndarray of shape (TEXTURE_SIZE, TEXTURE_SIZE, 3), uint8
        The texture.
    """
    n = 0.6 * fractal_noise(rng, base=3) + 0.4 * rng.random((TEXTURE_SIZE, TEXTURE_SIZE))
    return _finish(_as_rgb(colour) * (1.0 - grain + 2.0 * grain * n[..., None]))


def stripes(rng: np.random.Generator, colour, stripe_colour, period: int = 64) -> np.ndarray:
    """Paint a wall with a horizontal band pattern (a dado rail look).

    Parameters
    ----------
    rng : numpy.random.Generator
        The generator of the pattern's randomness.
    colour : sequence of float
        The base colour, RGB in 0..1.
    stripe_colour : sequence of float
        The bands' colour (mixed half and half with the wall's), RGB in 0..1.
    period : int, default 64
        Pixels per band and gap.

    Returns
    -------
    ndarray of shape (TEXTURE_SIZE, TEXTURE_SIZE, 3), uint8
        The texture.
    """
    img = painted(rng, colour).astype(np.float64) / 255.0
    rows = (np.arange(TEXTURE_SIZE) // (period // 2)) % 2 == 0
    band = np.zeros(TEXTURE_SIZE, bool)
    band[rows] = True
    img[band] = 0.5 * img[band] + 0.5 * _as_rgb(stripe_colour)[0]
    return _finish(img)


def bricks(rng: np.random.Generator, colour, mortar=(0.75, 0.73, 0.7), rows: int = 8) -> np.ndarray:
    """Lay a running-bond brick wall: per-brick colour variation, mortar joints, surface noise.

    Parameters
    ----------
    rng : numpy.random.Generator
        The generator of the pattern's randomness.
    colour : sequence of float
        The bricks' base colour, RGB in 0..1.
    mortar : sequence of float, default (0.75, 0.73, 0.7)
        The joints' colour, RGB in 0..1.
    rows : int, default 8
        Brick rows per texture.

    Returns
    -------
    ndarray of shape (TEXTURE_SIZE, TEXTURE_SIZE, 3), uint8
        The texture.
    """
    size = TEXTURE_SIZE
    h = size // rows
    w = 2 * h
    yy, xx = np.mgrid[0:size, 0:size]
    row = yy // h
    shifted = xx + (row % 2) * (w // 2)
    col = shifted // w
    # one random shade per brick, looked up by (row, col)
    shade = 0.8 + 0.35 * rng.random((rows + 1, size // w + 2))
    img = _as_rgb(colour) * shade[row, col][..., None]
    joint = ((yy % h) < 3) | ((shifted % w) < 3)
    img[joint] = _as_rgb(mortar)[0, 0]
    img *= (0.85 + 0.15 * fractal_noise(rng, base=16, octaves=2))[..., None]
    return _finish(img)


def tiles(
    rng: np.random.Generator, colour_a, colour_b, n: int = 4, grout=(0.3, 0.3, 0.3)
) -> np.ndarray:
    """Lay checkered floor tiles with grout lines and a slight per-tile shade.

    Parameters
    ----------
    rng : numpy.random.Generator
        The generator of the pattern's randomness.
    colour_a, colour_b : sequence of float
        The two tiles' colours, RGB in 0..1.
    n : int, default 4
        Tiles per side.
    grout : sequence of float, default (0.3, 0.3, 0.3)
        The grout lines' colour, RGB in 0..1.

    Returns
    -------
    ndarray of shape (TEXTURE_SIZE, TEXTURE_SIZE, 3), uint8
        The texture.
    """
    size = TEXTURE_SIZE
    cell = size // n
    yy, xx = np.mgrid[0:size, 0:size]
    checker = ((yy // cell + xx // cell) % 2).astype(bool)
    img = np.where(checker[..., None], _as_rgb(colour_a), _as_rgb(colour_b))
    img = img * (0.92 + 0.16 * rng.random((n, n)))[yy // cell, xx // cell][..., None]
    img = img * (0.9 + 0.1 * fractal_noise(rng, base=8))[..., None]
    grout_mask = ((yy % cell) < 2) | ((xx % cell) < 2)
    img[grout_mask] = _as_rgb(grout)[0, 0]
    return _finish(img)


def planks(rng: np.random.Generator, colour, n: int = 6) -> np.ndarray:
    """Lay wooden floor boards: grain streaks along x, a shade per board, dark seams.

    Parameters
    ----------
    rng : numpy.random.Generator
        The generator of the pattern's randomness.
    colour : sequence of float
        The wood's base colour, RGB in 0..1.
    n : int, default 6
        Boards per texture.

    Returns
    -------
    ndarray of shape (TEXTURE_SIZE, TEXTURE_SIZE, 3), uint8
        The texture.
    """
    size = TEXTURE_SIZE
    yy, _ = np.mgrid[0:size, 0:size]
    board = yy // (size // n)
    grain = cv2.resize(rng.random((size, 8)), (size, size), interpolation=cv2.INTER_CUBIC)
    grain = np.clip(grain, 0.0, 1.0)
    shade = 0.8 + 0.3 * rng.random(n + 1)
    img = _as_rgb(colour) * (shade[board] * (0.8 + 0.3 * grain))[..., None]
    img[(yy % (size // n)) < 2] *= 0.4
    return _finish(img)


def speckled(
    rng: np.random.Generator, colour, contrast: float = 0.35, base: int = 32
) -> np.ndarray:
    """Make carpet, asphalt, gravel or concrete: fine speckle over a low-frequency tone.

    Parameters
    ----------
    rng : numpy.random.Generator
        The generator of the pattern's randomness.
    colour : sequence of float
        The base colour, RGB in 0..1.
    contrast : float, default 0.35
        Relative strength of the speckle and tone.
    base : int, default 32
        Coarseness of the tone (its coarsest grid has ``base // 8`` cells per side).

    Returns
    -------
    ndarray of shape (TEXTURE_SIZE, TEXTURE_SIZE, 3), uint8
        The texture.
    """
    fine = rng.random((TEXTURE_SIZE, TEXTURE_SIZE))
    coarse = fractal_noise(rng, base=base // 8 or 1, octaves=3)
    n = 0.55 * fine + 0.45 * coarse
    return _finish(_as_rgb(colour) * (1.0 - contrast + 2.0 * contrast * n[..., None]))


def grass(rng: np.random.Generator, colour=(0.25, 0.5, 0.15)) -> np.ndarray:
    """Make lawn: blade-like vertical streaks in two greens, with patchy dry spots.

    Parameters
    ----------
    rng : numpy.random.Generator
        The generator of the pattern's randomness.
    colour : sequence of float, default (0.25, 0.5, 0.15)
        The grass's base colour, RGB in 0..1.

    Returns
    -------
    ndarray of shape (TEXTURE_SIZE, TEXTURE_SIZE, 3), uint8
        The texture.
    """
    size = TEXTURE_SIZE
    blades = cv2.resize(rng.random((size // 8, size)), (size, size), interpolation=cv2.INTER_LINEAR)
    patches = fractal_noise(rng, base=3)
    g = _as_rgb(colour) * (0.6 + 0.7 * blades[..., None])
    dry = _as_rgb((0.55, 0.5, 0.25))
    mix = np.clip((patches - 0.65) * 3.0, 0.0, 1.0)[..., None]
    return _finish(g * (1 - mix) + dry * mix * (0.7 + 0.5 * blades[..., None]))


def ceiling_tiles(rng: np.random.Generator, colour=(0.9, 0.9, 0.88)) -> np.ndarray:
    """Make a suspended ceiling: pale perforated tiles in a grey grid.

    Parameters
    ----------
    rng : numpy.random.Generator
        The generator of the pattern's randomness.
    colour : sequence of float, default (0.9, 0.9, 0.88)
        The tiles' colour, RGB in 0..1.

    Returns
    -------
    ndarray of shape (TEXTURE_SIZE, TEXTURE_SIZE, 3), uint8
        The texture.
    """
    size = TEXTURE_SIZE
    yy, xx = np.mgrid[0:size, 0:size]
    img = _as_rgb(colour) * (0.93 + 0.07 * rng.random((size, size)))[..., None]
    img[((yy % 128) < 4) | ((xx % 128) < 4)] = 0.55
    return _finish(img)


def poster(rng: np.random.Generator) -> np.ndarray:
    """Draw a poster: a few saturated blocks and discs on a light background (distinct per seed).

    Parameters
    ----------
    rng : numpy.random.Generator
        The generator of the pattern's randomness.

    Returns
    -------
    ndarray of shape (TEXTURE_SIZE, TEXTURE_SIZE, 3), uint8
        The texture.
    """
    size = TEXTURE_SIZE
    img = np.ones((size, size, 3)) * rng.uniform(0.75, 0.95, 3)
    yy, xx = np.mgrid[0:size, 0:size]
    for _ in range(int(rng.integers(3, 7))):
        colour = rng.uniform(0.05, 1.0, 3)
        if rng.random() < 0.5:
            x0, y0 = rng.integers(0, size - 40, 2)
            w, h = rng.integers(30, size // 2, 2)
            img[y0 : y0 + h, x0 : x0 + w] = colour
        else:
            cx, cy = rng.integers(30, size - 30, 2)
            r = rng.integers(15, size // 4)
            img[(xx - cx) ** 2 + (yy - cy) ** 2 < r * r] = colour
    return _finish(img)


def panelled_door(rng: np.random.Generator, colour=(0.45, 0.28, 0.15)) -> np.ndarray:
    """Make a wooden door: grain with two recessed panels.

    Parameters
    ----------
    rng : numpy.random.Generator
        The generator of the pattern's randomness.
    colour : sequence of float, default (0.45, 0.28, 0.15)
        The wood's base colour, RGB in 0..1.

    Returns
    -------
    ndarray of shape (TEXTURE_SIZE, TEXTURE_SIZE, 3), uint8
        The texture.
    """
    img = planks(rng, colour, n=1).astype(np.float64) / 255.0
    size = TEXTURE_SIZE
    for y0, y1 in ((20, 110), (140, 236)):
        img[y0:y1, 40:216] *= 0.8
        img[y0 : y0 + 3, 40:216] *= 0.6
        img[y0:y1, 40:43] *= 0.6
    img[size // 2 - 4 : size // 2 + 4, 200:215] = (0.8, 0.75, 0.4)  # handle
    return _finish(img)


def window_facade(rng: np.random.Generator, colour=(0.85, 0.8, 0.7)) -> np.ndarray:
    """Make house siding with a window: horizontal boards and a dark glazed rectangle.

    Parameters
    ----------
    rng : numpy.random.Generator
        The generator of the pattern's randomness.
    colour : sequence of float, default (0.85, 0.8, 0.7)
        The siding's colour, RGB in 0..1.

    Returns
    -------
    ndarray of shape (TEXTURE_SIZE, TEXTURE_SIZE, 3), uint8
        The texture.
    """
    size = TEXTURE_SIZE
    yy, _ = np.mgrid[0:size, 0:size]
    img = _as_rgb(colour) * (0.9 + 0.1 * ((yy % 16) > 2))[..., None] * np.ones((1, size, 1))
    img = img * (0.95 + 0.05 * rng.random((size, size)))[..., None]
    img[60:190, 70:186] = (0.95, 0.95, 0.95)
    img[68:182, 78:178] = (
        _as_rgb((0.15, 0.2, 0.3))[0, 0] + 0.1 * fractal_noise(rng, base=4)[68:182, 78:178, None]
    )
    img[122:128, 78:178] = 0.95
    img[68:182, 125:131] = 0.95
    return _finish(img)


def garage_door(rng: np.random.Generator, colour=(0.92, 0.92, 0.9)) -> np.ndarray:
    """Make a sectional garage door: horizontal ribbed panels.

    Parameters
    ----------
    rng : numpy.random.Generator
        The generator of the pattern's randomness.
    colour : sequence of float, default (0.92, 0.92, 0.9)
        The door's colour, RGB in 0..1.

    Returns
    -------
    ndarray of shape (TEXTURE_SIZE, TEXTURE_SIZE, 3), uint8
        The texture.
    """
    size = TEXTURE_SIZE
    yy, _ = np.mgrid[0:size, 0:size]
    rib = 0.75 + 0.25 * ((yy % 48) > 6)
    img = _as_rgb(colour) * rib[..., None] * (0.95 + 0.05 * rng.random((size, size)))[..., None]
    return _finish(img)


def encode_png(img: np.ndarray) -> bytes:
    """Encode an RGB image as PNG bytes (OpenCV stores BGR, hence the flip).

    Parameters
    ----------
    img : ndarray of shape (H, W, 3), uint8
        The image.

    Returns
    -------
    bytes
        The PNG file's content.
    """
    ok, buf = cv2.imencode(".png", np.ascontiguousarray(img[..., ::-1]))
    if not ok:  # pragma: no cover - cv2 only fails on invalid arrays
        raise RuntimeError("PNG encoding failed")
    return buf.tobytes()
