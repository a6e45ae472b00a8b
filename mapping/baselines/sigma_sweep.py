"""The paper's "Normalized Cuts" baseline as the paper ran it (Section III).

One Gaussian sigma for all clusters, swept over a grid, keeping the sigma with the lowest
clustering error on the true labels (an oracle choice: `mapping.baselines.label_free` chooses
without labels).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike
from sklearn.utils import check_array, column_or_1d

from mapping.baselines.spectral import NormalizedCutClustering
from mapping.distances import squared_distances
from mapping.metrics import check_labels, clustering_error

__all__ = ["SigmaSweep", "best_sigma_ncut", "default_sigmas"]


@dataclass(frozen=True)
class SigmaSweep:
    """Result of [`best_sigma_ncut`][mapping.baselines.sigma_sweep.best_sigma_ncut].

    The chosen sigma, its error and model, and the sweep.

    Parameters
    ----------
    sigma : float
        The sigma of the lowest error.
    error : float
        Its clustering error on the labels, a fraction in [0, 1].
    model : NormalizedCutClustering
        The NCut fitted at ``sigma``.
    sigmas, errors : ndarray of shape (n_sigmas,)
        Every sigma tried and its error.

    Attributes
    ----------
    sigma, error, model, sigmas, errors
        The parameters, stored as given (the object is frozen).

    Examples
    --------
    >>> import numpy as np
    >>> from mapping.baselines import best_sigma_ncut
    >>> rng = np.random.default_rng(0)
    >>> X = np.r_[rng.normal(0.0, 0.1, (20, 2)), rng.normal(3.0, 0.1, (20, 2))]
    >>> sweep = best_sigma_ncut(X, [0] * 20 + [1] * 20, n_clusters=2, sigmas=[0.3, 1.0, 3.0])
    >>> sweep.error, sweep.sigmas.tolist()
    (0.0, [0.3, 1.0, 3.0])

    See Also
    --------
    mapping.baselines.best_sigma_ncut : The sweep that returns this result.
    mapping.baselines.NormalizedCutClustering : The model swept.
    """

    sigma: float
    error: float
    model: NormalizedCutClustering
    sigmas: np.ndarray
    errors: np.ndarray


def default_sigmas(D2: np.ndarray, num: int = 40) -> np.ndarray:
    """Return log-spaced sigmas from half the median nearest-neighbour distance to the diameter.

    Parameters
    ----------
    D2 : ndarray of shape (n, n)
        Squared pairwise distances of the points.
    num : int, default 40
        Number of sigmas.

    Returns
    -------
    ndarray of shape (num,)
        The sigmas, ascending; the low end is ``1e-3`` times the diameter when every point
        has a copy.
    """
    off = D2 + np.diag(np.full(D2.shape[0], np.inf))
    nn = np.sqrt(off.min(axis=1))
    lo = 0.5 * float(np.median(nn[nn > 0])) if (nn > 0).any() else 0.0
    hi = float(np.sqrt(D2.max()))
    if not hi > 0:
        raise ValueError("X: all samples are identical")
    lo = lo if lo > 0 else 1e-3 * hi
    return np.geomspace(lo, hi, num)


def best_sigma_ncut(
    X: ArrayLike,
    y: ArrayLike,
    n_clusters: int,
    sigmas: ArrayLike | None = None,
    *,
    n_init: int = 10,
    random_state: int = 0,
) -> SigmaSweep:
    """Fit NCut for each sigma and keep the one with the lowest clustering error on ``y``.

    This is an *oracle* baseline, exactly as in the paper's Section III ("this value for sigma
    constitutes the lowest clustering error for the Normalized Cuts algorithm"): it looks at the
    true labels to choose sigma, an advantage no unsupervised method has. When several sigmas
    reach the lowest error, the middle one (by position in ``sigmas``) is kept.

    Parameters
    ----------
    X : array-like of shape (n, d)
        Data.
    y : array-like of shape (n,)
        True labels, used only to score each sigma with
        [`clustering_error`][mapping.metrics.clustering_error].
    n_clusters : int
        Number of clusters for every fit.
    sigmas : array-like, optional
        Candidate sigmas (> 0). Default: 40 log-spaced values from half the median
        nearest-neighbour distance to the largest pairwise distance.
    n_init, random_state : int
        Passed to [`NormalizedCutClustering`][mapping.baselines.spectral.NormalizedCutClustering].

    Returns
    -------
    SigmaSweep
        ``sigma``, ``error`` and fitted ``model`` of the best sigma, plus all ``sigmas`` and
        ``errors`` of the sweep.
    """
    X = check_array(X, dtype=np.float64, ensure_min_samples=2)
    y = check_labels(column_or_1d(y), "y")  # column_or_1d: an (n, 1) column as well
    if y.shape[0] != X.shape[0]:
        raise ValueError(
            f"X and y have inconsistent numbers of samples: {X.shape[0]} rows of X, "
            f"{y.shape[0]} labels in y"
        )
    probe = NormalizedCutClustering(n_clusters, n_init=n_init, random_state=random_state)
    probe._validate_params()
    probe._check_samples(X)  # once, not per sigma
    D2 = squared_distances(X)
    grid = default_sigmas(D2) if sigmas is None else _check_sigmas(sigmas)
    errors = np.full(grid.size, np.inf)
    for i, sigma in enumerate(grid):
        model = _fit_ncut(X, D2, n_clusters, float(sigma), n_init, random_state)
        if model is not None:
            errors[i] = clustering_error(y, model.labels_)
    if not np.isfinite(errors).any():
        raise ValueError("every sigma in sigmas gave an all-zero affinity; try larger sigmas")
    # Middle of the tied sigmas: a zero-error plateau is usually wide, and its edges are the
    # least robust choices (the small end is where affinities start to underflow).
    tied = np.flatnonzero(errors == errors.min())
    best = int(tied[(tied.size - 1) // 2])
    model = _fit_ncut(X, D2, n_clusters, float(grid[best]), n_init, random_state)
    return SigmaSweep(float(grid[best]), float(errors[best]), model, grid, errors)


def _check_sigmas(sigmas: ArrayLike) -> np.ndarray:
    """Return ``sigmas`` as a flat float array of positive finite numbers, or raise a ValueError."""
    form = "a non-empty sequence of positive finite numbers"
    try:
        grid = np.asarray(sigmas, dtype=np.float64).ravel()
    except (TypeError, ValueError):
        raise ValueError(f"sigmas must be {form}, got {sigmas!r}") from None
    if grid.size == 0 or not (np.isfinite(grid).all() and (grid > 0).all()):
        raise ValueError(f"sigmas must be {form}, got {sigmas!r}")
    return grid


def _fit_ncut(
    X: np.ndarray, D2: np.ndarray, n_clusters: int, sigma: float, n_init: int, random_state: int
) -> NormalizedCutClustering | None:
    """Fit on precomputed squared distances; None when every affinity underflows at sigma."""
    model = NormalizedCutClustering(n_clusters, sigma, n_init=n_init, random_state=random_state)
    model._validate_params()
    model._check_n_samples(X.shape[0])
    model.n_features_in_ = X.shape[1]  # what validate_data would have set in fit
    try:
        return model._fit_sqdist(X, D2)
    except ValueError:
        return None
