"""The four synthetic data sets of the paper's Section III-A (Figure 1a-d).

The paper shows the sets only as pictures and gives no coordinates; what the text fixes is:

(a) three parallel 2-D lines, points equally spaced on each;
(b) three lines, each sampled at a different interval;
(c) three 2-D paths converging at a single point, each sampled at a different interval;
(d) three 3-D spirals, each sampled at a different interval;

with K = 3 clusters, Q = 20 points per cluster at least, and best single sigmas for Normalized
Cuts of 0.085, 0.075, 0.079 and 0.051, i.e. the sets live on a unit scale with neighbouring
points a few hundredths apart. The defaults below follow that: curves of length 1-2, sampling
intervals from 0.01 to 0.05 (a ratio of 5 between the densest and the sparsest curve, so that
the sparsest still has 41 points, about 2 Q) and curves 0.13-0.3 apart. Lines 0.3 apart make
NCut at the paper's sigma for set (a), 0.085, separate set (a) as the paper reports. Each
curve's own interval stays below the distance to the other curves (apart from the junction of
set (c)), so every set is three 1-D manifolds that a nearest-neighbour chain separates. Each
generator documents its parameters; ``docs/guides/baselines.md`` shows the sets and the baselines.

Every generator returns ``(X, y)``: ``X`` of shape (n, 2) or (n, 3), float64, points ordered
cluster by cluster and along each curve (so index plots look like the paper's Figures 2-5), and
``y`` of shape (n,) with labels 0, 1, 2. They are deterministic; Gaussian noise of standard
deviation ``noise`` is added only when asked, and then needs an explicit ``rng``.
"""

from __future__ import annotations

from collections.abc import Callable, Iterable, Sequence

import numpy as np

from common.validation import is_real

__all__ = [
    "SYNTHETIC_SETS",
    "branching_sequences",
    "converging_paths",
    "lines_variable_spacing",
    "make_all",
    "parallel_lines",
    "plot_sets",
    "spirals_3d",
]

# Default sampling intervals of the three curves in sets (b)-(d): dense, medium, sparse.
_SPACINGS = (0.01, 0.025, 0.05)
# Points per curve at most (length / spacing): a million is far beyond the paper's sizes, and
# a spacing like 1e-300 would otherwise ask numpy for an impossible array.
_MAX_CURVE_POINTS = 1_000_000


def _check_positive(value: object, name: str) -> None:
    """Check ``value`` is a positive finite number, or raise a ValueError naming ``name``."""
    if not (is_real(value) and np.isfinite(value) and value > 0):
        raise ValueError(f"{name} must be a positive finite number, got {value!r}")


def _check_noise(noise: object) -> None:
    """Check ``noise`` is a non-negative finite number (a standard deviation)."""
    if not (is_real(noise) and np.isfinite(noise) and noise >= 0):
        raise ValueError(f"noise must be a non-negative number, got {noise!r}")


def _check_spacings(spacings: Sequence[float], length: float) -> tuple[float, float, float]:
    form = "three positive numbers, e.g. (0.01, 0.025, 0.05)"
    if isinstance(spacings, str | bytes) or not isinstance(spacings, Iterable):
        raise ValueError(f"spacings must be {form}, got {spacings!r}")
    values = tuple(spacings)
    if len(values) != 3 or not all(is_real(s) and np.isfinite(s) and s > 0 for s in values):
        raise ValueError(f"spacings must be {form}, got {values!r}")
    spacings = tuple(float(s) for s in values)
    _check_positive(length, "length")
    if max(spacings) > length:
        raise ValueError(f"spacings must not exceed length={length}, got {spacings!r}")
    if length / min(spacings) > _MAX_CURVE_POINTS:
        raise ValueError(
            f"spacings: length / spacing = {length / min(spacings):.3g} points on one curve; "
            f"at most {_MAX_CURVE_POINTS} (length={length}, spacings={spacings!r})"
        )
    return spacings


def _finish(
    parts: list[np.ndarray], noise: float, rng: np.random.Generator | None
) -> tuple[np.ndarray, np.ndarray]:
    """Stack the per-curve point arrays, label them 0, 1, 2 and add optional noise."""
    X = np.concatenate(parts).astype(np.float64)
    y = np.repeat(np.arange(len(parts)), [len(p) for p in parts])
    _check_noise(noise)
    if noise > 0:
        if not isinstance(rng, np.random.Generator):
            raise ValueError("noise > 0 needs rng, a numpy.random.Generator")
        X = X + rng.normal(scale=noise, size=X.shape)
    return X, y


def _arc_samples(length: float, spacing: float) -> np.ndarray:
    """Return arc-length positions 0, spacing, 2 spacing, ... <= length (end included if hit)."""
    n = int(np.floor(length / spacing + 1e-9)) + 1
    return np.arange(n) * spacing


def parallel_lines(
    n_per_line: int = 100,
    gap: float = 0.3,
    length: float = 1.0,
    *,
    noise: float = 0.0,
    rng: np.random.Generator | None = None,
) -> tuple[np.ndarray, np.ndarray]:
    """Figure 1a: three parallel horizontal lines, points equally spaced on each.

    Parameters
    ----------
    n_per_line : int, default 100
        Points per line (spacing ``length / (n_per_line - 1)``, 0.0101 by default).
    gap : float, default 0.3
        Vertical distance between neighbouring lines (y = 0, gap, 2 gap).
    length : float, default 1.0
        Length of each line (x from 0 to length).
    noise, rng
        Optional isotropic Gaussian noise; ``rng`` is required when ``noise > 0``.

    Returns
    -------
    X : ndarray of shape (n, 2)
        The points, curve by curve and along each curve.
    y : ndarray of int, shape (n,)
        Labels 0, 1, 2.
    """
    if isinstance(n_per_line, bool) or not isinstance(n_per_line, int | np.integer):
        raise ValueError(f"n_per_line must be an integer >= 2, got {n_per_line!r}")
    if n_per_line < 2:
        raise ValueError(f"n_per_line must be an integer >= 2, got {n_per_line!r}")
    _check_positive(gap, "gap")
    _check_positive(length, "length")
    x = np.linspace(0.0, length, n_per_line)
    parts = [np.column_stack([x, np.full_like(x, k * gap)]) for k in range(3)]
    return _finish(parts, noise, rng)


def lines_variable_spacing(
    spacings: Sequence[float] = _SPACINGS,
    gap: float = 0.3,
    length: float = 2.0,
    *,
    noise: float = 0.0,
    rng: np.random.Generator | None = None,
) -> tuple[np.ndarray, np.ndarray]:
    """Figure 1b: three parallel lines, each sampled at its own interval.

    Line k lies at y = k * gap and is sampled every ``spacings[k]`` from x = 0 to ``length``
    (201, 81 and 41 points by default). Compared with `parallel_lines` only the sampling
    intervals differ (and the lines are twice as long, so that the sparse one has 41 points).

    Parameters
    ----------
    spacings : three floats, default (0.01, 0.025, 0.05)
        Sampling interval of each line.
    gap : float, default 0.3
        Distance between neighbouring lines.
    length : float, default 2.0
        Length of each line.
    noise, rng
        Optional Gaussian noise; ``rng`` is required when ``noise > 0``.

    Returns
    -------
    X : ndarray of shape (n, 2)
        The points, curve by curve and along each curve.
    y : ndarray of int, shape (n,)
        Labels 0, 1, 2.
    """
    spacings = _check_spacings(spacings, length)
    _check_positive(gap, "gap")
    parts = []
    for k, h in enumerate(spacings):
        x = _arc_samples(length, h)
        parts.append(np.column_stack([x, np.full_like(x, k * gap)]))
    return _finish(parts, noise, rng)


def converging_paths(
    spacings: Sequence[float] = _SPACINGS,
    length: float = 2.0,
    turn: float = np.pi / 2,
    *,
    noise: float = 0.0,
    rng: np.random.Generator | None = None,
) -> tuple[np.ndarray, np.ndarray]:
    """Figure 1c: three paths that converge at one point, each sampled at its own interval.

    Modelled on the robot's branching corridor: all three paths leave the junction (the
    origin) heading along +x; path 0 turns left, path 1 goes straight, path 2 turns right, each
    turning arc of ``length`` bending by ``turn`` radians in total. Path k is sampled every
    ``spacings[k]`` of arc length, starting one interval away from the junction so that no two
    paths share a point. Near the junction the paths are closer than any sampling interval, so
    a few points there are ambiguous for every method.

    Parameters
    ----------
    spacings : three floats, default (0.01, 0.025, 0.05)
        Sampling interval (arc length) of the left, straight and right path (200, 80 and 40
        points by default).
    length : float, default 2.0
        Arc length of each path.
    turn : float, default pi / 2
        Total heading change of the turning paths, in radians (0 < turn <= pi).
    noise, rng
        Optional Gaussian noise; ``rng`` is required when ``noise > 0``.

    Returns
    -------
    X : ndarray of shape (n, 2)
        The points, curve by curve and along each curve.
    y : ndarray of int, shape (n,)
        Labels 0, 1, 2.
    """
    spacings = _check_spacings(spacings, length)
    if not (is_real(turn) and np.isfinite(turn) and 0 < turn <= np.pi):
        raise ValueError(f"turn must be in (0, pi], got {turn!r}")
    radius = length / turn
    parts = []
    for k, h in enumerate(spacings):
        s = _arc_samples(length, h)[1:]
        if k == 1:
            parts.append(np.column_stack([s, np.zeros_like(s)]))
            continue
        side = 1.0 if k == 0 else -1.0  # left turns towards +y
        phi = s / radius
        parts.append(np.column_stack([radius * np.sin(phi), side * radius * (1 - np.cos(phi))]))
    return _finish(parts, noise, rng)


def spirals_3d(
    spacings: Sequence[float] = (0.01, 0.02, 0.04),
    length: float = 2.0,
    radius: float = 0.15,
    pitch: float = 0.4,
    *,
    noise: float = 0.0,
    rng: np.random.Generator | None = None,
) -> tuple[np.ndarray, np.ndarray]:
    """Figure 1d: three interleaved 3-D spirals (helices), each sampled at its own interval.

    The helices share the z axis and radius and are rotated by 120 degrees from one another
    (a triple helix): helix k is ``(r cos(t + 2 pi k / 3), r sin(t + 2 pi k / 3), c t)`` with
    ``c = pitch / (2 pi)``, sampled every ``spacings[k]`` of arc length. Neighbouring strands
    are ``pitch / 3`` apart along z and ``sqrt(3) r`` apart across, so the sparse strand's
    interval is close to its distance from the other two.

    Parameters
    ----------
    spacings : three floats, default (0.01, 0.02, 0.04)
        Arc-length sampling interval of each helix (201, 101 and 51 points by default).
    length : float, default 2.0
        Arc length of each helix.
    radius : float, default 0.15
        Helix radius r.
    pitch : float, default 0.4
        Rise per full turn.
    noise, rng
        Optional Gaussian noise; ``rng`` is required when ``noise > 0``.

    Returns
    -------
    X : ndarray of shape (n, 3)
        The points, curve by curve and along each curve.
    y : ndarray of int, shape (n,)
        Labels 0, 1, 2.
    """
    spacings = _check_spacings(spacings, length)
    for name, value in (("radius", radius), ("pitch", pitch)):
        _check_positive(value, name)
    rise = pitch / (2 * np.pi)
    # Arc length per radian of the helix parameter t.
    speed = np.hypot(radius, rise)
    parts = []
    for k, h in enumerate(spacings):
        t = _arc_samples(length, h) / speed
        phase = 2 * np.pi * k / 3
        parts.append(
            np.column_stack([radius * np.cos(t + phase), radius * np.sin(t + phase), rise * t])
        )
    return _finish(parts, noise, rng)


#: Name -> generator of the paper's four sets, in the order of Figure 1a-d.
SYNTHETIC_SETS: dict[str, Callable[..., tuple[np.ndarray, np.ndarray]]] = {
    "parallel_lines": parallel_lines,
    "lines_variable_spacing": lines_variable_spacing,
    "converging_paths": converging_paths,
    "spirals_3d": spirals_3d,
}


def make_all(
    noise: float = 0.0, rng: np.random.Generator | None = None
) -> dict[str, tuple[np.ndarray, np.ndarray]]:
    """Return all four sets with default parameters, keyed as in `SYNTHETIC_SETS`.

    Parameters
    ----------
    noise : float, default 0.0
        Standard deviation of the Gaussian noise added to every set.
    rng : numpy.random.Generator, optional
        Source of the noise; required when ``noise > 0``.

    Returns
    -------
    dict of str to tuple of (ndarray, ndarray)
        Name -> ``(X, y)``.
    """
    return {name: make(noise=noise, rng=rng) for name, make in SYNTHETIC_SETS.items()}


def branching_sequences(
    n_per_seq: int, d: int, rng: np.random.Generator, noise: float = 0.02
) -> tuple[np.ndarray, np.ndarray]:
    """Return 8 smooth sequences in R^d shaped like the robot's two worlds.

    Per world a trunk and three branches leaving its end (speeds 0.03, 0.05, 0.08 against the
    trunk's 0.05).

    The same draws as ``bench/bench_manifold.py``'s benchmark data (identical output for the
    same generator), so the tables of ``experiments.manifold.sweeps`` and the speed benchmark use
    one data set. Each curve is ``start + t drift + sum_k (sin(f_k t + p_k) - sin p_k) u_k``
    with four random unit-scale directions u_k; labels 0..7 in order (trunk, 3 branches,
    trunk, 3 branches); isotropic noise ``noise / sqrt(d)`` per coordinate.

    Parameters
    ----------
    n_per_seq : int
        Points per sequence.
    d : int
        Dimension.
    rng : numpy.random.Generator
        Source of the curves and the noise.
    noise : float, default 0.02
        Noise scale.

    Returns
    -------
    X : ndarray of shape (8 * n_per_seq, d)
        The points, sequence by sequence.
    y : ndarray of int, shape (8 * n_per_seq,)
        Labels 0..7.
    """
    if isinstance(n_per_seq, bool) or not isinstance(n_per_seq, int | np.integer) or n_per_seq < 1:
        raise ValueError(f"n_per_seq must be a positive integer, got {n_per_seq!r}")
    if isinstance(d, bool) or not isinstance(d, int | np.integer) or d < 1:
        raise ValueError(f"d must be a positive integer, got {d!r}")
    if not isinstance(rng, np.random.Generator):
        raise ValueError("rng must be a numpy.random.Generator")
    _check_noise(noise)
    parts = []

    def curve(start: np.ndarray, speed: float) -> np.ndarray:
        t = np.arange(1, n_per_seq + 1)[:, None] * speed
        dirs = rng.normal(size=(4, d)) / np.sqrt(d)
        freq = rng.uniform(0.2, 1.0, size=4)
        phase = rng.uniform(0, 2 * np.pi, size=4)
        drift = rng.normal(size=d) / np.sqrt(d)
        return start + t * drift + (np.sin(t * freq + phase) - np.sin(phase)) @ dirs

    for _world in range(2):
        trunk = curve(rng.normal(size=d) * 9 / np.sqrt(d), 0.05)
        parts.append(trunk)
        for speed in (0.03, 0.05, 0.08):
            parts.append(curve(trunk[-1], speed))
    X = np.concatenate(parts)
    X += noise / np.sqrt(d) * rng.normal(size=X.shape)
    return X, np.repeat(np.arange(len(parts)), n_per_seq)


def plot_sets(path: str | None = None, sets: dict | None = None):
    """Plot the four sets side by side (the paper's Figure 1), coloured by true label.

    Parameters
    ----------
    path : str or path-like, optional
        Where to save the figure (PNG, via the Agg backend); if None it is only returned.
    sets : dict, optional
        ``name -> (X, y)``; defaults to `make_all`.

    Returns
    -------
    matplotlib.figure.Figure
        The figure, one panel per set.
    """
    # Imported here: matplotlib is slow to import and only this function needs it.
    from matplotlib.figure import Figure

    sets = make_all() if sets is None else sets
    fig = Figure(figsize=(4 * len(sets), 4), layout="constrained")
    colours = ("tab:red", "tab:blue", "tab:green")
    for i, (name, (X, y)) in enumerate(sets.items()):
        three_d = X.shape[1] == 3
        ax = fig.add_subplot(1, len(sets), i + 1, projection="3d" if three_d else None)
        for label in np.unique(y):
            pts = X[y == label]
            ax.scatter(*pts.T, s=6, color=colours[int(label) % 3], label=f"cluster {label}")
        if not three_d:
            ax.set_aspect("equal", adjustable="datalim")
        ax.set_title(f"({'abcd'[i]}) {name.replace('_', ' ')}\nn = {len(y)}")
    fig.axes[0].legend(loc="upper right", fontsize=7)
    if path is not None:
        fig.savefig(path, dpi=110)
    return fig
