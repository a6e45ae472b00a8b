"""The baselines a user would pick: spectral clusterings whose scale is chosen without labels.

* [`KNNSpectralClustering`][mapping.baselines.label_free.KNNSpectralClustering] -- scikit-learn's
  ``SpectralClustering(affinity=
  "nearest_neighbors")`` with the neighbour count either fixed (scikit-learn's default, 10) or
  chosen by the eigengap over a few candidates; new points take the majority cluster of their
  ``n_neighbors`` nearest training points (scikit-learn's ``KNeighborsClassifier``), since
  ``SpectralClustering`` itself has no ``predict``.
* [`EigengapNCutClustering`][mapping.baselines.label_free.EigengapNCutClustering] --
  [`NormalizedCutClustering`][mapping.baselines.spectral.NormalizedCutClustering] with
  the single sigma chosen by the eigengap of ``S = D^-1/2 W D^-1/2`` over a log grid; new
  points by its Nystrom extension.

The eigengap rule (von Luxburg, *A tutorial on spectral clustering*, 2007, Section 8.3): the
scale whose normalised affinity has the largest gap ``lambda_K - lambda_{K+1}`` between its
K-th and (K+1)-th largest eigenvalue, i.e. the graph closest to K disconnected parts. It looks
at the data only, never at labels, unlike
[`best_sigma_ncut`][mapping.baselines.sigma_sweep.best_sigma_ncut], the paper's oracle, which is
kept as a ceiling.
"""

from __future__ import annotations

from numbers import Integral

import numpy as np
from numpy.typing import ArrayLike
from scipy.linalg import LinAlgError, eigh
from sklearn.base import BaseEstimator, ClusterMixin, _fit_context
from sklearn.cluster import SpectralClustering
from sklearn.neighbors import KNeighborsClassifier, kneighbors_graph
from sklearn.utils._param_validation import Interval, StrOptions
from sklearn.utils.validation import check_is_fitted, validate_data

from common.blas import single_threaded_blas
from mapping.baselines.sigma_sweep import default_sigmas
from mapping.baselines.spectral import NormalizedCutClustering
from mapping.distances import squared_distances
from mapping.validation import check_distinct_rows, check_span

__all__ = ["EigengapNCutClustering", "KNNSpectralClustering", "eigengap"]

#: Neighbour counts the eigengap rule of `KNNSpectralClustering` chooses from.
DEFAULT_NEIGHBOR_CANDIDATES = (5, 7, 10, 15, 20, 30)


def eigengap(affinity: np.ndarray, n_clusters: int) -> float:
    """Return ``lambda_K - lambda_{K+1}`` of ``D^-1/2 W D^-1/2`` (eigenvalues largest first).

    Isolated points (degree 0) are given degree 1, so that they contribute eigenvalue 0 instead
    of a division by zero.

    Parameters
    ----------
    affinity : ndarray of shape (n, n)
        Dense symmetric affinity W with zero diagonal.
    n_clusters : int
        K, in ``[1, n)``.

    Returns
    -------
    float
        The gap between the K-th and (K+1)-th largest eigenvalue.
    """
    W = np.asarray(affinity, dtype=np.float64)
    n = W.shape[0]
    if not 1 <= n_clusters < n:
        raise ValueError(f"n_clusters must be in [1, n_samples), got {n_clusters} for n={n}")
    deg = W.sum(axis=1)
    inv = 1.0 / np.sqrt(np.where(deg > 0, deg, 1.0))
    S = inv[:, None] * W * inv[None, :]
    with single_threaded_blas():
        top = _top_eigenvalues(S, n_clusters + 1)
    return float(top[1] - top[0])  # ascending: top[0] is lambda_{K+1}, top[1] is lambda_K


def _top_eigenvalues(S: np.ndarray, count: int) -> np.ndarray:
    """Return the ``count`` largest eigenvalues of the symmetric S, ascending.

    LAPACK's subset solver (syevr) can fail ("Internal Error") on a spectrum of large
    clusters of equal eigenvalues, as copies of a point (a robot standing still) make at some
    sigmas; the full divide-and-conquer solver then gives the same values.
    """
    n = S.shape[0]
    try:
        return eigh(S, eigvals_only=True, subset_by_index=[n - count, n - 1])
    except LinAlgError:
        return eigh(S, eigvals_only=True, driver="evd")[n - count :]


def _check_training_points(X: np.ndarray, n_clusters: int) -> None:
    """Check the training points can be clustered into ``n_clusters``.

    At least ``n_clusters`` samples, as many distinct ones, and a span float64 distances can
    hold (1e200 overflows them, 1e-200 underflows them to "all identical").
    """
    if n_clusters > X.shape[0]:
        raise ValueError(f"n_clusters={n_clusters} exceeds n_samples ({X.shape[0]})")
    if not check_span(X) > 0:
        raise ValueError("X: all samples are identical; there is nothing to cluster")
    check_distinct_rows(X, n_clusters)


class KNNSpectralClustering(ClusterMixin, BaseEstimator):
    """scikit-learn's kNN-graph spectral clustering, k fixed or chosen by the eigengap.

    Parameters
    ----------
    n_clusters : int, default 2
        Number of clusters K.
    n_neighbors : int or "eigengap", default 10
        Neighbours of the graph (10 is scikit-learn's default); ``"eigengap"`` picks, among
        ``candidates`` smaller than n, the k whose symmetrised kNN graph (as scikit-learn
        builds it, ``(A + A^T) / 2``) has the largest
        [`eigengap`][mapping.baselines.label_free.eigengap].
    candidates : tuple of int, default (5, 7, 10, 15, 20, 30)
        Neighbour counts tried by the eigengap rule.
    random_state : int, default 0
        Seed of scikit-learn's eigensolver start and k-means.

    Attributes
    ----------
    labels_ : ndarray of shape (n,)
    n_neighbors_ : int
        The neighbour count used.
    gaps_ : dict
        k -> eigengap, for the candidates tried (empty for a fixed k).

    Examples
    --------
    >>> import numpy as np
    >>> rng = np.random.default_rng(0)
    >>> X = np.r_[rng.normal(0.0, 0.5, (20, 2)), rng.normal(2.0, 0.5, (20, 2))]
    >>> from mapping.baselines import KNNSpectralClustering
    >>> model = KNNSpectralClustering(n_clusters=2, n_neighbors="eigengap").fit(X)
    >>> np.bincount(model.labels_).tolist(), model.n_neighbors_
    ([20, 20], 20)

    See Also
    --------
    mapping.baselines.eigengap : The rule that picks the neighbour count.
    mapping.baselines.EigengapNCutClustering : The same rule choosing NCut's sigma.
    sklearn.cluster.SpectralClustering : The clustering this estimator runs.
    """

    _parameter_constraints: dict = {
        "n_clusters": [Interval(Integral, 1, None, closed="left")],
        "n_neighbors": [Interval(Integral, 1, None, closed="left"), StrOptions({"eigengap"})],
        "candidates": [tuple, list],
        "random_state": [Interval(Integral, 0, 2**32 - 1, closed="both")],
    }

    def __init__(
        self,
        n_clusters: int = 2,
        n_neighbors: int | str = 10,
        *,
        candidates: tuple = DEFAULT_NEIGHBOR_CANDIDATES,
        random_state: int = 0,
    ) -> None:
        self.n_clusters = n_clusters
        self.n_neighbors = n_neighbors
        self.candidates = candidates
        self.random_state = random_state

    def _choose_k(self, X: np.ndarray) -> int:
        n = X.shape[0]
        if self.n_neighbors != "eigengap":
            if self.n_neighbors >= n:
                raise ValueError(f"n_neighbors={self.n_neighbors} must be < n_samples ({n})")
            return int(self.n_neighbors)
        ks = sorted({int(k) for k in self.candidates if 1 <= int(k) < n})
        if not ks:
            raise ValueError(f"candidates: no neighbour count below n_samples ({n})")
        if self.n_clusters >= n:
            raise ValueError(f"n_clusters={self.n_clusters} must be < n_samples ({n})")
        for k in ks:
            A = kneighbors_graph(X, k, include_self=True)
            self.gaps_[k] = eigengap((0.5 * (A + A.T)).toarray() - np.eye(n), self.n_clusters)
        return max(ks, key=lambda k: (self.gaps_[k], -k))

    @_fit_context(prefer_skip_nested_validation=True)
    def fit(self, X: ArrayLike, y: None = None) -> KNNSpectralClustering:
        """Cluster the rows of X.

        Parameters
        ----------
        X : array-like of shape (n, d)
            Training points.
        y : None
            Ignored.

        Returns
        -------
        KNNSpectralClustering
            This estimator, fitted.
        """
        X = validate_data(self, X, dtype=np.float64, ensure_min_samples=2)
        _check_training_points(X, self.n_clusters)
        self.gaps_ = {}
        self.n_neighbors_ = self._choose_k(X)
        model = SpectralClustering(
            self.n_clusters,
            affinity="nearest_neighbors",
            n_neighbors=self.n_neighbors_,
            random_state=self.random_state,
        )
        self.labels_ = model.fit_predict(X).astype(np.intp)
        self.classifier_ = KNeighborsClassifier(min(self.n_neighbors_, X.shape[0])).fit(
            X, self.labels_
        )
        return self

    def predict(self, X: ArrayLike) -> np.ndarray:
        """Return the majority cluster of each point's ``n_neighbors_`` nearest training points.

        Parameters
        ----------
        X : array-like of shape (m, d)
            Points to label.

        Returns
        -------
        ndarray of shape (m,)
            Cluster of each point.
        """
        check_is_fitted(self, "labels_")
        X = validate_data(self, X, dtype=np.float64, reset=False)
        return self.classifier_.predict(X).astype(np.intp)


class EigengapNCutClustering(ClusterMixin, BaseEstimator):
    """Normalised cuts with one sigma, chosen by the eigengap instead of the labels.

    Parameters
    ----------
    n_clusters : int, default 2
        Number of clusters K.
    n_sigmas : int, default 25
        Size of the log grid of [`default_sigmas`][mapping.baselines.sigma_sweep.default_sigmas]
        (half the median nearest-neighbour distance to the diameter) that the rule searches.
    n_init : int, default 10
        k-means restarts.
    random_state : int, default 0
        Seed of the k-means initialisation.

    Attributes
    ----------
    labels_ : ndarray of shape (n,)
    sigma_ : float
        The sigma of the largest [`eigengap`][mapping.baselines.label_free.eigengap].
    sigmas_, gaps_ : ndarray
        The grid and the eigengap at each sigma (-inf where every affinity underflows).
    model_ : NormalizedCutClustering
        The NCut fitted at ``sigma_``; ``predict`` is its Nystrom extension.

    Examples
    --------
    >>> import numpy as np
    >>> rng = np.random.default_rng(0)
    >>> X = np.r_[rng.normal(0.0, 0.1, (20, 2)), rng.normal(3.0, 0.1, (20, 2))]
    >>> from mapping.baselines import EigengapNCutClustering
    >>> model = EigengapNCutClustering(n_clusters=2, n_sigmas=10).fit(X)
    >>> np.bincount(model.labels_).tolist(), bool(model.sigma_ in model.sigmas_)
    ([20, 20], True)

    See Also
    --------
    mapping.baselines.eigengap : The rule that picks sigma.
    mapping.baselines.NormalizedCutClustering : The model fitted at the chosen sigma.
    mapping.baselines.best_sigma_ncut : Sigma chosen on the labels instead.
    """

    _parameter_constraints: dict = {
        "n_clusters": [Interval(Integral, 1, None, closed="left")],
        "n_sigmas": [Interval(Integral, 2, None, closed="left")],
        "n_init": [Interval(Integral, 1, None, closed="left")],
        "random_state": [Interval(Integral, 0, 2**32 - 1, closed="both")],
    }

    def __init__(
        self, n_clusters: int = 2, *, n_sigmas: int = 25, n_init: int = 10, random_state: int = 0
    ) -> None:
        self.n_clusters = n_clusters
        self.n_sigmas = n_sigmas
        self.n_init = n_init
        self.random_state = random_state

    @_fit_context(prefer_skip_nested_validation=True)
    def fit(self, X: ArrayLike, y: None = None) -> EigengapNCutClustering:
        """Choose sigma by the eigengap, then fit NCut with it.

        Parameters
        ----------
        X : array-like of shape (n, d)
            Training points.
        y : None
            Ignored.

        Returns
        -------
        EigengapNCutClustering
            This estimator, fitted.
        """
        X = validate_data(self, X, dtype=np.float64, ensure_min_samples=2)
        n = X.shape[0]
        _check_training_points(X, self.n_clusters)
        D2 = squared_distances(X)
        self.sigmas_ = default_sigmas(D2, self.n_sigmas)
        self.gaps_ = np.full(self.sigmas_.size, -np.inf)
        if self.n_clusters < n:
            for i, sigma in enumerate(self.sigmas_):
                W = np.exp(-D2 / (2.0 * sigma**2))
                np.fill_diagonal(W, 0.0)
                if W.any():
                    self.gaps_[i] = eigengap(W, self.n_clusters)
        # no gap to compare (K = n or every affinity underflows): the largest sigma
        best = int(np.argmax(self.gaps_)) if np.isfinite(self.gaps_).any() else -1
        self.sigma_ = float(self.sigmas_[best])
        self.model_ = NormalizedCutClustering(
            self.n_clusters, self.sigma_, n_init=self.n_init, random_state=self.random_state
        ).fit(X)
        self.labels_ = self.model_.labels_
        return self

    def predict(self, X: ArrayLike) -> np.ndarray:
        """Label new points by the Nystrom extension of the NCut at ``sigma_``.

        See ``NormalizedCutClustering``.

        Parameters
        ----------
        X : array-like of shape (m, d)
            Points to label.

        Returns
        -------
        ndarray of shape (m,)
            Cluster of each point.
        """
        check_is_fitted(self, "labels_")
        X = validate_data(self, X, dtype=np.float64, reset=False)
        return self.model_.predict(X)
