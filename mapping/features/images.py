"""Images to fixed-length feature vectors, for both mapping methods.

The paper clusters raw pixels (3 x 320 x 240 values per image, Section III-B).
[`images_to_vectors`][mapping.features.images.images_to_vectors] keeps that as the default and adds
a resolution, colour or grey, and a normalisation;
[`ImageFeatures`][mapping.features.images.ImageFeatures] wraps it with an optional PCA projection
fitted on the training images (scikit-learn's ``PCA``). The compact alternative that reproduces the
paper's image result here, per-cell HSV histograms, is in `mapping.features.hsv_histograms`.

Everything is vectorised over images; the only Python loop is one OpenCV call per image.
"""

from __future__ import annotations

from numbers import Integral

import cv2
import numpy as np
from numpy.typing import ArrayLike
from sklearn.base import BaseEstimator, TransformerMixin, _fit_context
from sklearn.decomposition import PCA
from sklearn.utils._param_validation import Interval, StrOptions, validate_params
from sklearn.utils.validation import check_is_fitted

from mapping.features.image_input import image_transformer_tags, positive_pair

__all__ = ["IMAGE_NORMALIZATIONS", "ImageFeatures", "images_to_vectors", "normalize_rows"]

IMAGE_NORMALIZATIONS = ("none", "unit", "standardize")
# ITU-R BT.601 luma weights, the ones cv2.cvtColor uses for RGB -> grey.
_LUMA = np.array([0.299, 0.587, 0.114])


_SHAPES = "(n, H, W, 3), (n, H, W), (H, W, 3) or (H, W)"
_VALUES = "uint8, uint16, other integers in 0-255, or floats in [0, 1] (or 0-255)"


def _image_batch(images: np.ndarray) -> np.ndarray:
    """Return ``images`` as a batch ``(n, H, W, 3)`` or ``(n, H, W)``.

    (H, W) is one grey image, (H, W, 3) one colour image and any other 3-D array a grey batch,
    except a last axis of 4: RGBA, refused (one RGBA image would be read as H grey images 4
    pixels wide).
    """
    if images.ndim in (3, 4) and images.shape[0] == 0:
        raise ValueError("images is empty")
    if images.ndim in (3, 4) and images.shape[-1] == 4:
        raise ValueError(
            f"images must have shape {_SHAPES}, got {images.shape}: RGBA? pass images[..., :3]"
        )
    if images.ndim == 2 or (images.ndim == 3 and images.shape[-1] == 3):
        images = images[None]
    if images.ndim not in (3, 4) or (images.ndim == 4 and images.shape[-1] != 3):
        raise ValueError(f"images must have shape {_SHAPES}, got {images.shape}")
    if images.shape[1] == 0 or images.shape[2] == 0:
        raise ValueError(f"images must have pixels, got {images.shape[1]}x{images.shape[2]}")
    return images


def _pixel_scale(images: np.ndarray) -> float:
    """Return the factor that maps ``images`` to [0, 1].

    The rule is that of [`images_to_vectors`][mapping.features.images.images_to_vectors].

    uint8 and uint16 go by their type, with no pass over the pixels. A float copy of 8-bit
    pixels (what ``servo`` passes on) gives what the uint8 image gives.
    """
    kind = images.dtype.kind
    if images.dtype == np.uint8:
        return 1.0 / 255.0
    if images.dtype == np.uint16:
        return 1.0 / 65535.0
    if kind not in "uif":
        raise ValueError(f"images must be {_VALUES}; got dtype {images.dtype}")
    if kind == "f" and not np.isfinite(images).all():
        raise ValueError("images contain NaN or inf")
    lo, hi = images.min(), images.max()
    if lo < 0 or hi > 255:
        raise ValueError(f"images must be {_VALUES}; got {images.dtype} values in [{lo}, {hi}]")
    return 1.0 if kind == "f" and hi <= 1 else 1.0 / 255.0


def images_to_vectors(
    images: ArrayLike, size: tuple[int, int] | None = None, color: bool = True
) -> np.ndarray:
    """Flatten images into rows of pixel values in [0, 1].

    Parameters
    ----------
    images : array-like of shape (H, W, 3), (H, W), (n, H, W, 3) or (n, H, W)
        One image or a batch; RGB or grey. uint8 is scaled by 1/255, uint16 by 1/65535,
        other integers must lie in 0-255 (scaled by 1/255); floats in [0, 1] are kept, and
        floats in 0-255 with some value above 1 are 8-bit values, scaled by 1/255 (a float
        copy of an all-dark 8-bit frame, every value <= 1, is thus read as [0, 1]: pass
        uint8 to be sure). Anything else raises ValueError. A 3-D array whose last axis has
        length 3 is one RGB image, otherwise grey images; a last axis of 4 (RGBA) is refused.
    size : (width, height), optional
        Resample to this resolution with ``cv2.INTER_AREA`` (pixel-area averaging, which does
        not alias when shrinking). None keeps the native resolution, as the paper did.
    color : bool, default True
        Keep the three channels; False converts RGB to grey (BT.601 luma).

    Returns
    -------
    ndarray of shape (n, width * height * channels), float64
    """
    images = _image_batch(np.asarray(images))
    scale = _pixel_scale(images)
    if size is not None:
        width, height = positive_pair(size, "size", "(width, height)")
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
    if scale != 1.0:
        out *= scale
    return out.reshape(out.shape[0], -1)


@validate_params(
    {"X": ["array-like"], "method": [StrOptions({"none", "unit"})]},
    prefer_skip_nested_validation=True,
)
def normalize_rows(X: np.ndarray, method: str = "unit") -> np.ndarray:
    """Normalise each vector: ``"unit"`` subtracts each row's mean and scales it to norm 1.

    This removes global brightness and contrast changes between views. A constant row (zero
    norm after centring) stays all zeros. ``"none"`` returns X unchanged (as float64). X must
    be 2-D, one vector per row (``X[None]`` for a single vector), and finite: a row with a NaN
    has no norm (it became all zeros, a constant image, before).

    Parameters
    ----------
    X : ndarray of shape (n, d)
        Finite vectors, one per row.
    method : {"unit", "none"}, default "unit"
        The normalisation.

    Returns
    -------
    ndarray of shape (n, d)
        The normalised rows, float64.
    """
    X = np.asarray(X, dtype=np.float64)
    if X.ndim != 2:
        raise ValueError(f"X must be 2-D, one vector per row (X[None] for one), got {X.shape}")
    finite = np.isfinite(X).all(axis=1)
    if not finite.all():
        bad = np.flatnonzero(~finite)
        raise ValueError(f"X must be finite; rows {bad[:5].tolist()} hold NaN or inf")
    if method == "none":
        return X
    X = X - X.mean(axis=1, keepdims=True)
    norms = np.linalg.norm(X, axis=1, keepdims=True)
    return np.divide(X, norms, out=np.zeros_like(X), where=norms > 0)


class ImageFeatures(TransformerMixin, BaseEstimator):
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
        Project onto this many principal components of the training vectors (scikit-learn's
        ``PCA`` with the exact SVD solver, so no randomness enters; at most the number of
        training images).

    Attributes
    ----------
    n_features_in_ : int
        Pixel values per image after resizing and colour conversion.
    mean_, scale_ : ndarray of shape (n_features_in_,)
        Per-pixel statistics ("standardize" only).
    pca_mean_ : ndarray of shape (n_features_in_,)
    components_ : ndarray of shape (n_components, n_features_in_)
        Orthonormal principal axes; the largest-magnitude entry of each is positive
        (scikit-learn's sign rule), so the projection is the same across runs and platforms.
    explained_variance_ : ndarray of shape (n_components,)
        The PCA projection (``n_components`` only), copied from the fitted ``PCA`` so that the
        fitted state is plain arrays.

    Examples
    --------
    >>> import numpy as np
    >>> from mapping.features import ImageFeatures
    >>> images = np.random.default_rng(0).integers(0, 256, (5, 60, 80, 3), dtype=np.uint8)
    >>> ImageFeatures(size=(8, 6), color=False, normalization="unit").fit_transform(images).shape
    (5, 48)
    >>> ImageFeatures(size=(8, 6), n_components=3).fit_transform(images).shape
    (5, 3)

    See Also
    --------
    mapping.features.ColorHistogramFeatures : Colour histograms instead of pixels.
    mapping.features.images_to_vectors : The pixels as rows, without resizing.
    mapping.manifold.ManifoldClustering : The method that clusters these vectors.
    """

    _parameter_constraints: dict = {
        "size": ["array-like", None],
        "color": ["boolean"],
        "normalization": [StrOptions(set(IMAGE_NORMALIZATIONS))],
        "n_components": [Interval(Integral, 1, None, closed="left"), None],
    }

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

    def __sklearn_tags__(self):
        """Return scikit-learn's tags, marking the input as a batch of images."""
        return image_transformer_tags(super().__sklearn_tags__())

    def _pixels(self, images: ArrayLike) -> np.ndarray:
        X = images_to_vectors(images, self.size, self.color)
        return normalize_rows(X, "unit" if self.normalization == "unit" else "none")

    @_fit_context(prefer_skip_nested_validation=True)
    def fit(self, images: ArrayLike, y: None = None) -> ImageFeatures:
        """Learn the standardisation and PCA (if any) from training images.

        Parameters
        ----------
        images : array-like of shape (n, H, W, 3) or (n, H, W)
            Training images (see [`images_to_vectors`][mapping.features.images.images_to_vectors]).
        y : None
            Ignored.

        Returns
        -------
        ImageFeatures
            This transformer, fitted.
        """
        X = self._pixels(images)
        self.n_features_in_ = X.shape[1]
        if self.normalization == "standardize":
            self.mean_ = X.mean(axis=0)
            std = X.std(axis=0)
            # Constant pixels (e.g. a uniform sky) carry no information: leave them centred at 0.
            self.scale_ = np.where(std > 0, std, 1.0)
            X = (X - self.mean_) / self.scale_
        if self.n_components is not None:
            if X.shape[0] < 2:  # one image has no variance (PCA would divide 0 by 0)
                raise ValueError(
                    f"n_components={self.n_components} needs at least 2 training images for "
                    f"the PCA, got {X.shape[0]}"
                )
            pca = PCA(self.n_components, svd_solver="full").fit(X)
            self.pca_mean_ = pca.mean_
            self.components_ = pca.components_
            self.explained_variance_ = pca.explained_variance_
        return self

    def transform(self, images: ArrayLike) -> np.ndarray:
        """Return the feature vectors of the images.

        Parameters
        ----------
        images : array-like of shape (n, H, W, 3) or (n, H, W)
            Images (see [`images_to_vectors`][mapping.features.images.images_to_vectors]).

        Returns
        -------
        ndarray of shape (n, n_components or n_features_in_)
            One feature vector per image.
        """
        check_is_fitted(self, "n_features_in_")
        X = self._pixels(images)
        if X.shape[1] != self.n_features_in_:
            raise ValueError(
                f"images give {X.shape[1]} values per image, fitted with {self.n_features_in_}; "
                "check size and color"
            )
        if self.normalization == "standardize":
            X = (X - self.mean_) / self.scale_
        if self.n_components is not None:
            # PCA.transform without whitening, from the stored arrays
            X = (X - self.pca_mean_) @ self.components_.T
        return X
