"""Input checks and the BLAS thread policy shared by the estimators of ``mapping``."""

from __future__ import annotations

import numpy as np
from numpy.typing import ArrayLike
from threadpoolctl import ThreadpoolController

_CONTROLLER: ThreadpoolController | None = None


def single_threaded_blas():
    """Context running BLAS on one thread.

    The manifold search does hundreds of eigendecompositions of matrices of a few hundred rows
    and ``predict`` hundreds of small solves; OpenBLAS gains little from threads at that size
    and, on a busy 2-core machine, its spinning threads made a 600-point fit 6x slower
    (3 s -> 20 s) and ``predict`` of 450 views 8x slower (0.3 s -> 2.3 s). Big Gram products
    run outside this context and keep all threads.
    """
    global _CONTROLLER
    if _CONTROLLER is None:  # scanning the loaded libraries costs ~2 ms; do it once
        _CONTROLLER = ThreadpoolController()
    return _CONTROLLER.limit(limits=1, user_api="blas")


class NotFittedError(ValueError, AttributeError):
    """Raised when an estimator is used before ``fit`` (same bases as scikit-learn's)."""


def check_array(
    X: ArrayLike, name: str = "X", min_samples: int = 2, keep_float32: bool = False
) -> np.ndarray:
    """X as a finite, C-contiguous 2-D float array; float64 unless ``keep_float32`` and X is
    float32 already. Refuses non-numeric data, wrong rank, too few samples, no features,
    NaN and infinity, naming ``name``."""
    X = np.asarray(X)
    if X.dtype.kind not in "biuf":
        raise ValueError(f"{name} must be numeric, got dtype {X.dtype}")
    dtype = np.float32 if keep_float32 and X.dtype == np.float32 else np.float64
    X = np.ascontiguousarray(X, dtype=dtype)
    if X.ndim != 2:
        raise ValueError(f"{name} must be a 2-D array (n_samples, n_features), got shape {X.shape}")
    if X.shape[0] < min_samples:
        raise ValueError(f"{name} needs at least {min_samples} samples, got {X.shape[0]}")
    if X.shape[1] == 0:
        raise ValueError(f"{name} has no features (shape[1] == 0)")
    if not np.isfinite(X).all():
        raise ValueError(f"{name} contains NaN or infinity")
    return X


def check_fitted_input(estimator: object, X: ArrayLike, keep_float32: bool = False) -> np.ndarray:
    """New points for a fitted estimator: fitted, then :func:`check_array`, then the feature
    count of ``fit`` (``n_features_in_``)."""
    if not hasattr(estimator, "labels_"):
        raise NotFittedError(
            f"this {type(estimator).__name__} is not fitted yet; call fit(X) before using it"
        )
    X = check_array(X, min_samples=1, keep_float32=keep_float32)
    expected = estimator.n_features_in_  # type: ignore[attr-defined]
    if X.shape[1] != expected:
        raise ValueError(
            f"X has {X.shape[1]} features, but {type(estimator).__name__} was fitted with "
            f"{expected} features (n_features_in_)"
        )
    return X
