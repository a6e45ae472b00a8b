"""Per-cell HSV colour histograms of images.

The compact image features that reproduce the paper's image result here
(docs/decisions/010-image-features.md).

Each cell's histogram is square-rooted so that Euclidean distance between feature vectors is
the Hellinger distance between the cells' colour distributions. The only Python loop is one
OpenCV colour conversion per image.
"""

from __future__ import annotations

import cv2
import numpy as np
from numpy.typing import ArrayLike
from sklearn.base import BaseEstimator, TransformerMixin, _fit_context
from sklearn.utils.validation import check_is_fitted

from mapping.features.image_input import image_transformer_tags, positive_pair

__all__ = ["ColorHistogramFeatures", "color_histograms"]


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
    nb = np.asarray(bins)  # ints only: 4.5 bins is not 4
    if nb.dtype.kind not in "iu" or nb.shape != (3,) or (nb < 1).any():
        raise ValueError(f"bins must be three positive ints (hue, saturation, value), got {bins}")
    nb = nb.astype(np.int64)
    cols, rows = positive_pair(grid, "grid", "(columns, rows)")
    n, H, W, _ = arr.shape
    if n == 0:
        raise ValueError("images is empty")
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


class ColorHistogramFeatures(TransformerMixin, BaseEstimator):
    """Images -> per-cell HSV histograms, a transformer.

    The histograms are those of
    [`color_histograms`][mapping.features.hsv_histograms.color_histograms].

    Stateless apart from remembering the feature count, so ``fit`` only validates; it exists
    so that this and [`ImageFeatures`][mapping.features.images.ImageFeatures] are interchangeable in
    a pipeline.

    Parameters
    ----------
    bins : (hue, saturation, value), default (8, 4, 4)
    grid : (columns, rows), default (2, 2)
        See [`color_histograms`][mapping.features.hsv_histograms.color_histograms].

    Attributes
    ----------
    n_features_in_ : int
        Values per image, ``columns * rows * prod(bins)``.

    Examples
    --------
    >>> import numpy as np
    >>> from mapping.features import ColorHistogramFeatures
    >>> images = np.zeros((3, 60, 80, 3), dtype=np.uint8)
    >>> ColorHistogramFeatures(bins=(8, 4, 4), grid=(2, 2)).fit_transform(images).shape
    (3, 512)

    See Also
    --------
    mapping.features.color_histograms : The function this transformer wraps.
    mapping.features.ImageFeatures : The pixels themselves as features.
    """

    _parameter_constraints: dict = {"bins": ["array-like"], "grid": ["array-like"]}

    def __init__(
        self, bins: tuple[int, int, int] = (8, 4, 4), grid: tuple[int, int] = (2, 2)
    ) -> None:
        self.bins = bins
        self.grid = grid

    def __sklearn_tags__(self):
        """Return scikit-learn's tags, marking the input as a batch of images."""
        return image_transformer_tags(super().__sklearn_tags__())

    @_fit_context(prefer_skip_nested_validation=True)
    def fit(self, images: ArrayLike, y: None = None) -> ColorHistogramFeatures:
        """Check the parameters and images; remember the feature count.

        Parameters
        ----------
        images : array-like of uint8, shape (H, W, 3) or (n, H, W, 3)
            RGB images; only the first is converted.
        y : None
            Ignored.

        Returns
        -------
        ColorHistogramFeatures
            This transformer, fitted.
        """
        arr = np.asarray(images)
        # the first image checks the lot: one (H, W, 3) image is a batch of one, not H rows
        first = arr if arr.ndim <= 3 else arr[:1]  # fewer axes: refused, naming the form
        self.n_features_in_ = color_histograms(first, self.bins, self.grid).shape[1]
        return self

    def transform(self, images: ArrayLike) -> np.ndarray:
        """Return the feature vectors of the images.

        Parameters
        ----------
        images : array-like of uint8, shape (H, W, 3) or (n, H, W, 3)
            RGB images.

        Returns
        -------
        ndarray of shape (n, cells * prod(bins))
            Per-cell square-rooted histograms.
        """
        check_is_fitted(self, "n_features_in_")
        return color_histograms(images, self.bins, self.grid)
