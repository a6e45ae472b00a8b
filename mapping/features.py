"""Sensor readings to fixed-length feature vectors, so both sensors feed both mapping methods.

Images: the paper clusters raw pixels (3 x 320 x 240 values per image, Section III-B).
:func:`images_to_vectors` keeps that as the default and adds a resolution, colour or grey, and
a normalisation; :class:`ImageFeatures` wraps it with an optional PCA projection fitted on the
training images. :func:`color_histograms` / :class:`ColorHistogramFeatures` are the compact
alternative that reproduces the paper's image result here: per-cell HSV histograms, square-rooted
so that Euclidean distance is the Hellinger distance (docs/manifold-clustering.md, "Images").

Laser scans: float32 range arrays of shape (n_beams,) or (n, n_beams), where ``+inf`` means
"no return within max range" and NaN an invalid reading. :func:`scan_ranges` makes them finite
(both become ``max_range``), :func:`scan_vectors` turns them into a range, inverse-range or
polar occupancy-grid vector, and :class:`ScanFeatures` wraps that. :func:`scan_to_points` gives
the returns as points in the sensor frame (x forward, y left; beam angles in radians,
counter-clockwise from x).

Everything is vectorised over images and beams; the only Python loop is one ``cv2.resize`` per
image.
"""

from __future__ import annotations

import cv2
import numpy as np
from numpy.typing import ArrayLike

__all__ = [
    "IMAGE_NORMALIZATIONS",
    "SCAN_REPRESENTATIONS",
    "ColorHistogramFeatures",
    "ImageFeatures",
    "ScanFeatures",
    "color_histograms",
    "fit_pca",
    "images_to_vectors",
    "normalize_rows",
    "scan_ranges",
    "scan_to_points",
    "scan_vectors",
]

IMAGE_NORMALIZATIONS = ("none", "unit", "standardize")
SCAN_REPRESENTATIONS = ("range", "inverse", "polar_grid")
# ITU-R BT.601 luma weights, the ones cv2.cvtColor uses for RGB -> grey.
_LUMA = np.array([0.299, 0.587, 0.114])


def _choice(value: str, name: str, options: tuple[str, ...]) -> str:
    if value not in options:
        raise ValueError(f"{name} must be one of {options}, got {value!r}")
    return value


def images_to_vectors(
    images: ArrayLike, size: tuple[int, int] | None = None, color: bool = True
) -> np.ndarray:
    """Flatten images into rows of pixel values in [0, 1].

    Parameters
    ----------
    images : array-like of shape (H, W, 3), (H, W), (n, H, W, 3) or (n, H, W)
        One image or a batch; RGB or grey; uint8 (0-255) or float (already in [0, 1]). A 3-D
        array whose last axis has length 3 is read as one RGB image, otherwise as grey images.
    size : (width, height), optional
        Resample to this resolution with ``cv2.INTER_AREA`` (pixel-area averaging, which does
        not alias when shrinking). None keeps the native resolution, as the paper did.
    color : bool, default True
        Keep the three channels; False converts RGB to grey (BT.601 luma).

    Returns
    -------
    ndarray of shape (n, width * height * channels), float64
    """
    images = np.asarray(images)
    if images.dtype.kind not in "uif":
        raise ValueError(f"images must be numeric, got dtype {images.dtype}")
    # (H, W) is one grey image and (H, W, 3) one colour image; (n, H, W) a grey batch.
    if images.ndim == 2 or (images.ndim == 3 and images.shape[-1] == 3):
        images = images[None]
    if images.ndim not in (3, 4) or (images.ndim == 4 and images.shape[-1] != 3):
        raise ValueError(
            f"images must have shape (n, H, W, 3), (n, H, W), (H, W, 3) or (H, W), "
            f"got {np.shape(images)}"
        )
    if images.shape[0] == 0:
        raise ValueError("images is empty")
    if images.dtype.kind == "f" and not np.isfinite(images).all():
        raise ValueError("images contain NaN or inf")
    if size is not None:
        width, height = (int(v) for v in size)
        if width < 1 or height < 1:
            raise ValueError(f"size must be (width, height) with both >= 1, got {size!r}")
    else:
        height, width = images.shape[1:3]
    grey = not color and images.ndim == 4
    channels = 1 if grey or images.ndim == 3 else 3
    # Integers are exact in float32 (cv2's fastest float type); float input keeps float64.
    work = np.float32 if images.dtype.kind in "ui" else np.float64
    out = np.empty((images.shape[0], height, width, channels))
    # One image at a time: the output is the only full-size float copy of the batch.
    for i, im in enumerate(images):
        im = im.astype(work, copy=False)
        if size is not None:
            im = cv2.resize(im, (width, height), interpolation=cv2.INTER_AREA)
        out[i] = (im @ _LUMA)[..., None] if grey else im.reshape(height, width, channels)
    if images.dtype == np.uint8:
        out *= 1.0 / 255.0
    return out.reshape(out.shape[0], -1)


def normalize_rows(X: np.ndarray, method: str = "unit") -> np.ndarray:
    """Per-vector normalisation: ``"unit"`` subtracts each row's mean and scales it to norm 1.

    This removes global brightness and contrast changes between views. A constant row (zero
    norm after centring) stays all zeros. ``"none"`` returns X unchanged (as float64).
    """
    _choice(method, "method", ("none", "unit"))
    X = np.asarray(X, dtype=np.float64)
    if method == "none":
        return X
    X = X - X.mean(axis=1, keepdims=True)
    norms = np.linalg.norm(X, axis=1, keepdims=True)
    return np.divide(X, norms, out=np.zeros_like(X), where=norms > 0)


def fit_pca(X: np.ndarray, n_components: int) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Principal axes of X by a thin SVD of the centred data.

    Signs are fixed so that the largest-magnitude entry of every component is positive, which
    makes the projection identical across runs and platforms.

    Returns
    -------
    mean : ndarray of shape (d,)
    components : ndarray of shape (n_components, d), orthonormal rows
    explained_variance : ndarray of shape (n_components,)
    """
    X = np.asarray(X, dtype=np.float64)
    n, d = X.shape
    if not 1 <= n_components <= min(n, d):
        raise ValueError(f"n_components must be in [1, {min(n, d)}] for data of shape {X.shape}")
    mean = X.mean(axis=0)
    _, s, vt = np.linalg.svd(X - mean, full_matrices=False)
    vt = vt[:n_components]
    signs = np.sign(vt[np.arange(n_components), np.abs(vt).argmax(axis=1)])
    vt = vt * np.where(signs == 0, 1.0, signs)[:, None]
    return mean, vt, s[:n_components] ** 2 / max(n - 1, 1)


class ImageFeatures:
    """Images -> feature vectors: resolution, colour, normalisation, optional PCA.

    Parameters
    ----------
    size : (width, height), optional
        Target resolution (``cv2.INTER_AREA``); None keeps the input resolution.
    color : bool, default True
        RGB (True) or grey (False).
    normalization : {"none", "unit", "standardize"}, default "none"
        "unit": each image zero-mean and unit-norm (invariant to brightness and contrast);
        "standardize": each pixel standardised with the mean and std of the training images.
        "none" is the paper's raw pixels.
    n_components : int, optional
        Project onto this many principal components of the training vectors.

    Attributes
    ----------
    n_features_in_ : int
        Pixel values per image after resizing and colour conversion.
    mean_, scale_ : ndarray
        Per-pixel statistics ("standardize" only).
    pca_mean_, components_, explained_variance_ : ndarray
        The PCA projection (``n_components`` only).
    """

    def __init__(
        self,
        size: tuple[int, int] | None = None,
        color: bool = True,
        normalization: str = "none",
        n_components: int | None = None,
    ) -> None:
        self.size = size
        self.color = color
        self.normalization = normalization
        self.n_components = n_components

    def _pixels(self, images: ArrayLike) -> np.ndarray:
        X = images_to_vectors(images, self.size, self.color)
        return normalize_rows(X, "unit" if self.normalization == "unit" else "none")

    def fit(self, images: ArrayLike, y: None = None) -> ImageFeatures:
        """Learn the standardisation and PCA (if any) from training images."""
        _choice(self.normalization, "normalization", IMAGE_NORMALIZATIONS)
        X = self._pixels(images)
        self.n_features_in_ = X.shape[1]
        if self.normalization == "standardize":
            self.mean_ = X.mean(axis=0)
            std = X.std(axis=0)
            # Constant pixels (e.g. a uniform sky) carry no information: leave them centred at 0.
            self.scale_ = np.where(std > 0, std, 1.0)
            X = (X - self.mean_) / self.scale_
        if self.n_components is not None:
            self.pca_mean_, self.components_, self.explained_variance_ = fit_pca(
                X, self.n_components
            )
        self.fitted_ = True
        return self

    def transform(self, images: ArrayLike) -> np.ndarray:
        """Feature vectors of shape (n, n_components or n_features_in_)."""
        if not getattr(self, "fitted_", False):
            raise ValueError("ImageFeatures is not fitted yet; call fit(images) first")
        X = self._pixels(images)
        if X.shape[1] != self.n_features_in_:
            raise ValueError(
                f"images give {X.shape[1]} values per image, fitted with {self.n_features_in_}; "
                "check size and color"
            )
        if self.normalization == "standardize":
            X = (X - self.mean_) / self.scale_
        if self.n_components is not None:
            X = (X - self.pca_mean_) @ self.components_.T
        return X

    def fit_transform(self, images: ArrayLike, y: None = None) -> np.ndarray:
        """``fit(images).transform(images)``."""
        return self.fit(images).transform(images)


def _grid(value: object) -> tuple[int, int]:
    try:
        cols, rows = (int(v) for v in value)  # type: ignore[union-attr]
    except (TypeError, ValueError):
        raise ValueError(f"grid must be (columns, rows) of positive ints, got {value!r}") from None
    if cols < 1 or rows < 1:
        raise ValueError(f"grid must be (columns, rows) of positive ints, got {value!r}")
    return cols, rows


def color_histograms(
    images: ArrayLike, bins: tuple[int, int, int] = (8, 4, 4), grid: tuple[int, int] = (2, 2)
) -> np.ndarray:
    """Square-rooted HSV histograms of each cell of a grid over each image.

    Parameters
    ----------
    images : array-like of uint8, shape (H, W, 3) or (n, H, W, 3)
        RGB images.
    bins : (hue, saturation, value) bins
        Hue bins cover OpenCV's 0-179, the others 0-255, all equally wide.
    grid : (columns, rows)
        Cells per image; each gets its own histogram, so a little layout survives.

    Returns
    -------
    ndarray of shape (n, columns * rows * prod(bins))
        Per cell, ``sqrt(count / pixels of the cell)``: each cell's part has unit norm and the
        Euclidean distance between two rows is sqrt(2 * cells) times the root-mean-square
        Hellinger distance of their cells.
    """
    arr = np.asarray(images)
    if arr.ndim == 3:
        arr = arr[None]
    if arr.ndim != 4 or arr.shape[-1] != 3 or arr.dtype != np.uint8:
        raise ValueError(
            f"images must be uint8 RGB of shape (H, W, 3) or (n, H, W, 3), got {arr.dtype} "
            f"{arr.shape}"
        )
    nb = np.asarray(bins, dtype=np.int64)
    if nb.shape != (3,) or (nb < 1).any():
        raise ValueError(f"bins must be three positive ints (hue, saturation, value), got {bins}")
    cols, rows = _grid(grid)
    n, H, W, _ = arr.shape
    if H < rows or W < cols:
        raise ValueError(f"grid {grid} has more cells than the {W}x{H} image has pixels")
    cell = (np.arange(H) * rows // H)[:, None] * cols + (np.arange(W) * cols // W)[None, :]
    n_bins = int(nb.prod())
    per_image = n_bins * cols * rows
    # Per-pixel (cell, bin) code as a lookup: one table per channel, added up in int32.
    tops = (180, 256, 256)  # OpenCV's 8-bit hue is 0-179
    lut = [(np.arange(256) * k // top).astype(np.int32) for k, top in zip(nb, tops, strict=True)]
    stride = (int(nb[1] * nb[2]), int(nb[2]), 1)
    base = (cell * n_bins).astype(np.int32)
    counts = np.empty((n, per_image), dtype=np.float64)
    for i, im in enumerate(arr):  # one image at a time keeps the working set in cache
        hsv = cv2.cvtColor(im, cv2.COLOR_RGB2HSV)
        code = base + lut[0][hsv[..., 0]] * stride[0]
        code += lut[1][hsv[..., 1]] * stride[1] + lut[2][hsv[..., 2]]
        counts[i] = np.bincount(code.ravel(), minlength=per_image)
    counts = counts.reshape(n, cols * rows, n_bins)
    pixels = np.bincount(cell.ravel(), minlength=cols * rows)
    return np.sqrt(counts / pixels[None, :, None]).reshape(n, per_image)


class ColorHistogramFeatures:
    """Images -> per-cell HSV histograms (:func:`color_histograms`), a transformer.

    Stateless apart from remembering the feature count, so ``fit`` only validates; it exists
    so that this and :class:`ImageFeatures` are interchangeable in a pipeline.
    """

    def __init__(
        self, bins: tuple[int, int, int] = (8, 4, 4), grid: tuple[int, int] = (2, 2)
    ) -> None:
        self.bins = bins
        self.grid = grid

    def fit(self, images: ArrayLike, y: None = None) -> ColorHistogramFeatures:
        """Check the parameters and images; remember the feature count."""
        first = np.asarray(images)[:1]
        self.n_features_in_ = color_histograms(first, self.bins, self.grid).shape[1]
        return self

    def transform(self, images: ArrayLike) -> np.ndarray:
        """Feature vectors of shape (n, cells * prod(bins))."""
        if not hasattr(self, "n_features_in_"):
            raise ValueError("ColorHistogramFeatures is not fitted yet; call fit(images) first")
        return color_histograms(images, self.bins, self.grid)

    def fit_transform(self, images: ArrayLike, y: None = None) -> np.ndarray:
        """``fit(images).transform(images)``."""
        return self.fit(images).transform(images)


def scan_ranges(ranges: ArrayLike, max_range: float) -> np.ndarray:
    """Finite ranges in [0, max_range], shape (n, n_beams), float64.

    ``+inf`` (no return) and values beyond ``max_range`` become ``max_range``; NaN, ``-inf`` and
    negative readings are invalid and are also treated as "nothing seen" (``max_range``), the
    conservative choice that never invents an obstacle.
    """
    if not (np.isfinite(max_range) and max_range > 0):
        raise ValueError(f"max_range must be a positive finite number, got {max_range!r}")
    r = np.asarray(ranges, dtype=np.float64)
    if r.ndim == 1:
        r = r[None]
    if r.ndim != 2 or r.shape[1] == 0:
        raise ValueError(f"ranges must have shape (n_beams,) or (n, n_beams), got {r.shape}")
    invalid = np.isnan(r) | (r < 0)
    return np.where(invalid, max_range, np.minimum(r, max_range))


def scan_vectors(
    ranges: ArrayLike,
    max_range: float,
    representation: str = "range",
    *,
    min_range: float = 0.05,
    n_sectors: int | None = None,
    n_range_bins: int = 8,
) -> np.ndarray:
    """Scans to fixed-length vectors.

    Parameters
    ----------
    ranges : array-like of shape (n_beams,) or (n, n_beams)
        Raw ranges; inf = no return, NaN = invalid (see :func:`scan_ranges`).
    max_range : float
        Sensor range limit in metres.
    representation : {"range", "inverse", "polar_grid"}, default "range"
        "range": ``r / max_range`` in [0, 1] per beam (or sector).
        "inverse": ``min_range / r - min_range / max_range``, which stresses near obstacles and
        maps "no return" to 0.
        "polar_grid": an occupancy histogram over (angle sector, range bin): the fraction of the
        sector's beams whose return falls in each range bin; beams without return add nothing.
    min_range : float, default 0.05
        Ranges are clipped below at this value for "inverse".
    n_sectors : int, optional
        Pool beams into this many equal angular sectors. "range"/"inverse" keep the nearest
        return per sector (min-pooling), which is robust to a single missed beam; "polar_grid"
        needs it (default 16 there). Sectors are runs of consecutive beams (beams are assumed
        to be ordered by angle, as a scanner reports them), as even as ``np.array_split``.
    n_range_bins : int, default 8
        Range bins of "polar_grid", equal width over [0, max_range).

    Returns
    -------
    ndarray of shape (n, D), float64
    """
    _choice(representation, "representation", SCAN_REPRESENTATIONS)
    r = scan_ranges(ranges, max_range)
    n, n_beams = r.shape
    if n_sectors is None and representation == "polar_grid":
        n_sectors = min(16, n_beams)
    if n_sectors is not None and not 1 <= n_sectors <= n_beams:
        raise ValueError(f"n_sectors must be in [1, n_beams={n_beams}], got {n_sectors!r}")
    # First beam of each sector; np.minimum.reduceat pools each sector in one call.
    starts = np.linspace(0, n_beams, (n_sectors or n_beams) + 1).astype(int)[:-1]

    if representation == "polar_grid":
        if n_range_bins < 1:
            raise ValueError(f"n_range_bins must be >= 1, got {n_range_bins!r}")
        sector = np.repeat(np.arange(n_sectors), np.diff(np.append(starts, n_beams)))
        rbin = np.minimum((r / max_range * n_range_bins).astype(int), n_range_bins - 1)
        hit = r < max_range
        cell = (np.arange(n)[:, None] * n_sectors + sector[None, :]) * n_range_bins + rbin
        grid = np.bincount(cell[hit], minlength=n * n_sectors * n_range_bins).astype(np.float64)
        grid = grid.reshape(n, n_sectors, n_range_bins)
        beams_per_sector = np.bincount(sector, minlength=n_sectors).astype(np.float64)
        return (grid / beams_per_sector[None, :, None]).reshape(n, -1)

    if n_sectors is not None:
        r = np.minimum.reduceat(r, starts, axis=1)
    if representation == "range":
        return r / max_range
    if not 0 < min_range < max_range:
        raise ValueError(f"min_range must be in (0, max_range={max_range}), got {min_range!r}")
    return min_range / np.maximum(r, min_range) - min_range / max_range


class ScanFeatures:
    """Laser scans -> feature vectors (a fit/transform wrapper of :func:`scan_vectors`).

    Parameters
    ----------
    max_range : float
        Sensor range limit in metres.
    representation : {"range", "inverse", "polar_grid"}, default "range"
    n_sectors : int, optional
    min_range : float, default 0.05
    n_range_bins : int, default 8
        See :func:`scan_vectors`.

    Attributes
    ----------
    n_beams_ : int
        Beams per scan seen in ``fit``; ``transform`` requires the same.
    """

    def __init__(
        self,
        max_range: float,
        representation: str = "range",
        *,
        n_sectors: int | None = None,
        min_range: float = 0.05,
        n_range_bins: int = 8,
    ) -> None:
        self.max_range = max_range
        self.representation = representation
        self.n_sectors = n_sectors
        self.min_range = min_range
        self.n_range_bins = n_range_bins

    def fit(self, ranges: ArrayLike, y: None = None) -> ScanFeatures:
        """Record the number of beams and check the parameters on the training scans."""
        r = scan_ranges(ranges, self.max_range)
        self.n_beams_ = r.shape[1]
        self.transform(r)
        return self

    def transform(self, ranges: ArrayLike) -> np.ndarray:
        """Feature vectors of shape (n, D)."""
        if not hasattr(self, "n_beams_"):
            raise ValueError("ScanFeatures is not fitted yet; call fit(ranges) first")
        r = np.asarray(ranges)
        n_beams = r.shape[-1] if r.ndim in (1, 2) else None
        if n_beams != self.n_beams_:
            raise ValueError(
                f"ranges must have {self.n_beams_} beams per scan, got shape {r.shape}"
            )
        return scan_vectors(
            r,
            self.max_range,
            self.representation,
            min_range=self.min_range,
            n_sectors=self.n_sectors,
            n_range_bins=self.n_range_bins,
        )

    def fit_transform(self, ranges: ArrayLike, y: None = None) -> np.ndarray:
        """``fit(ranges).transform(ranges)``."""
        return self.fit(ranges).transform(ranges)


def scan_to_points(
    ranges: ArrayLike, angles: ArrayLike, max_range: float | None = None
) -> np.ndarray:
    """Returns of one scan as 2-D points in the sensor frame (x forward, y left).

    Parameters
    ----------
    ranges : array-like of shape (n_beams,)
        Ranges in metres; inf (no return), NaN, negative values and, if ``max_range`` is
        given, readings at or beyond it are dropped.
    angles : array-like of shape (n_beams,)
        Beam angles in radians, counter-clockwise from the x axis.
    max_range : float, optional
        Drop readings ``>= max_range`` (sensors that report max range instead of inf).

    Returns
    -------
    ndarray of shape (M, 2), float64, M <= n_beams
    """
    r = np.asarray(ranges, dtype=np.float64)
    a = np.asarray(angles, dtype=np.float64)
    if r.ndim != 1 or a.shape != r.shape:
        raise ValueError(
            f"ranges and angles must be 1-D of the same length, got {r.shape} and {a.shape}"
        )
    keep = np.isfinite(r) & (r >= 0) & np.isfinite(a)
    if max_range is not None:
        keep &= r < max_range
    r, a = r[keep], a[keep]
    return np.column_stack([r * np.cos(a), r * np.sin(a)])
