"""Spectral clustering baselines the paper's method is compared with.

* [`NormalizedCutClustering`][mapping.baselines.spectral.NormalizedCutClustering] -- normalised
  spectral clustering with one Gaussian sigma for
  all clusters, the "Normalized Cuts" baseline of Section III;
  [`mapping.baselines.sigma_sweep.best_sigma_ncut`][mapping.baselines.sigma_sweep.best_sigma_ncut]
  sweeps sigma and keeps the one with the lowest clustering error on the true labels, as the paper
  did.
* [`SelfTuningSpectralClustering`][mapping.baselines.spectral.SelfTuningSpectralClustering] -- local
  scaling (Zelnik-Manor & Perona, 2004): each
  point gets its own sigma, the distance to its ``n_neighbors``-th neighbour; the stronger,
  modern baseline.

Both follow Ng, Jordan & Weiss [15]: ``S = D^-1/2 W D^-1/2`` (the same normalised affinity the
paper builds in Section II-A), the top ``n_clusters`` eigenvectors of S as an embedding, rows
scaled to unit length, k-means (scikit-learn's ``KMeans``) in the embedding. New points are
embedded with the Nystrom out-of-sample extension of Bengio et al. [22], which the paper used
for its NCut test error.
"""

from __future__ import annotations

from numbers import Integral, Real

import numpy as np
from numpy.typing import ArrayLike
from scipy.linalg import eigh
from sklearn.base import BaseEstimator, ClusterMixin, TransformerMixin, _fit_context
from sklearn.cluster import KMeans
from sklearn.metrics import pairwise_distances_argmin
from sklearn.utils._param_validation import Interval
from sklearn.utils.validation import check_is_fitted, validate_data

from common.blas import single_threaded_blas
from mapping.distances import TINY as _TINY
from mapping.distances import squared_distances
from mapping.validation import check_distinct_rows, check_span, first_copies

__all__ = ["NormalizedCutClustering", "SelfTuningSpectralClustering"]


def _unit_rows(E: np.ndarray) -> np.ndarray:
    norms = np.linalg.norm(E, axis=1, keepdims=True)
    return E / np.maximum(norms, _TINY)


class _SpectralBase(ClusterMixin, TransformerMixin, BaseEstimator):
    """Shared NJW pipeline; subclasses define the affinity of training and new points."""

    _parameter_constraints: dict = {
        "n_clusters": [Interval(Integral, 1, None, closed="left")],
        "n_init": [Interval(Integral, 1, None, closed="left")],
        # an int seed only: the results are reproducible by construction
        "random_state": [Interval(Integral, 0, 2**32 - 1, closed="both")],
    }

    def _affinity(self, D2: np.ndarray) -> np.ndarray:  # pragma: no cover - abstract
        raise NotImplementedError

    def _affinity_new(self, D2_new: np.ndarray) -> np.ndarray:  # pragma: no cover - abstract
        raise NotImplementedError

    def _check_n_samples(self, n_samples: int) -> None:
        """Run the checks the parameter constraints cannot express (they depend on the data)."""
        if self.n_clusters > n_samples:
            raise ValueError(
                f"n_clusters={self.n_clusters} exceeds the number of samples ({n_samples})"
            )

    def _check_samples(self, X: np.ndarray) -> None:
        """Check the training points themselves.

        Their number, a span float64 distances can hold, and at least ``n_clusters`` distinct
        rows.
        """
        self._check_n_samples(X.shape[0])
        if not check_span(X) > 0:
            raise ValueError("X: all samples are identical; there is nothing to cluster")
        check_distinct_rows(X, self.n_clusters)

    @_fit_context(prefer_skip_nested_validation=True)
    def fit(self, X: ArrayLike, y: None = None) -> _SpectralBase:
        """Cluster the rows of X; sets ``labels_`` and the state ``predict`` needs.

        Parameters
        ----------
        X : array-like of shape (n, d)
            Finite training points, not all identical.
        y : None
            Ignored; present for scikit-learn compatibility.
        """
        X = validate_data(self, X, dtype=np.float64, ensure_min_samples=2)
        self._check_samples(X)
        return self._fit_sqdist(X, squared_distances(X))

    def _fit_sqdist(self, X: np.ndarray, D2: np.ndarray) -> _SpectralBase:
        if not D2.max() > 0:
            raise ValueError("X: all samples are identical; there is nothing to cluster")
        W = self._affinity(D2)
        np.fill_diagonal(W, 0.0)
        deg = W.sum(axis=1)
        if not (deg > _TINY).any():
            raise ValueError("the affinity underflows to 0 for every pair; the scale is too small")
        inv_sqrt = 1.0 / np.sqrt(np.maximum(deg, _TINY))
        S = inv_sqrt[:, None] * W * inv_sqrt[None, :]
        n, k = S.shape[0], self.n_clusters
        with single_threaded_blas():  # a few hundred rows: threads only contend (see there)
            evals, evecs = eigh(S, subset_by_index=[n - k, n - 1])
        # eigh returns ascending order; the embedding uses the largest first.
        evals, evecs = evals[::-1], evecs[:, ::-1]
        # Sign convention (largest-magnitude entry positive) makes the embedding reproducible.
        flip = np.sign(evecs[np.abs(evecs).argmax(axis=0), np.arange(k)])
        evecs = evecs * np.where(flip == 0, 1.0, flip)
        embedding = _unit_rows(evecs)
        kmeans = KMeans(k, n_init=self.n_init, random_state=self.random_state).fit(embedding)

        self.X_fit_ = X
        self.affinity_matrix_ = W
        self.degrees_ = deg
        self.eigenvalues_ = evals
        self.eigenvectors_ = evecs
        self.embedding_ = embedding
        self.cluster_centers_ = kmeans.cluster_centers_
        self.labels_ = kmeans.labels_.astype(np.intp)
        return self

    def _check_query(self, X: ArrayLike) -> np.ndarray:
        check_is_fitted(self, "labels_")
        return validate_data(self, X, dtype=np.float64, reset=False)

    def _nystrom(self, X: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Embedding of new points, their affinity sums and squared distances to training."""
        D2 = squared_distances(self.X_fit_, X).T
        W_new = self._affinity_new(D2)
        d_new = W_new.sum(axis=1)
        K = W_new / np.sqrt(np.maximum(d_new, _TINY))[:, None]
        K /= np.sqrt(np.maximum(self.degrees_, _TINY))[None, :]
        # Guard the division: a near-zero eigenvalue only occurs for an almost empty graph.
        lam = np.where(np.abs(self.eigenvalues_) > 1e-12, self.eigenvalues_, 1e-12)
        return _unit_rows((K @ self.eigenvectors_) / lam), d_new, D2

    def transform(self, X: ArrayLike) -> np.ndarray:
        """Nystrom embedding of new points (Bengio et al. [22]), rows of unit length.

        ``e_k(x) = 1 / lambda_k * sum_i W(x, x_i) / sqrt(d(x) d_i) v_ik`` with ``d(x)`` the sum
        of x's affinities to the training points and ``d_i`` the training degrees. For a
        training point this is its own embedding row except that ``W(x_j, x_j)``, left out of
        the training affinity, now counts; the difference vanishes as the degrees grow.
        """
        return self._nystrom(self._check_query(X))[0]

    def predict(self, X: ArrayLike) -> np.ndarray:
        """Assign new points to the nearest k-means centre of their Nystrom embedding.

        A point whose affinity to every training point underflows to 0 (far from all data at
        this scale) has no Nystrom embedding; it takes the label of its nearest training point.
        """
        E, d_new, D2 = self._nystrom(self._check_query(X))
        labels = pairwise_distances_argmin(E, self.cluster_centers_).astype(np.intp)
        isolated = d_new <= _TINY
        if isolated.any():
            labels[isolated] = self.labels_[D2[isolated].argmin(axis=1)]
        return labels


class NormalizedCutClustering(_SpectralBase):
    """Normalised spectral clustering with a single Gaussian sigma (the paper's NCut baseline).

    Affinity ``W_ij = exp(-|x_i - x_j|^2 / (2 sigma^2))``, ``W_ii = 0``, normalised as
    ``S = D^-1/2 W D^-1/2`` exactly as in Section II-A of the paper; the top ``n_clusters``
    eigenvectors of S, row-normalised, are clustered with k-means (Ng, Jordan & Weiss [15]; the
    eigenvectors of S are Shi & Malik's [14] generalised eigenvectors scaled by ``D^1/2``).

    Parameters
    ----------
    n_clusters : int, default 2
        Number of clusters K (>= 1).
    sigma : float, default 1.0
        Gaussian kernel width, the same for every cluster; > 0.
    n_init : int, default 10
        k-means restarts (``KMeans``); the run with the lowest inertia is kept.
    random_state : int, default 0
        Seed of the k-means initialisation (results are deterministic for a seed).

    Attributes
    ----------
    labels_ : ndarray of shape (n,)
        Cluster of each training point, in 0..n_clusters-1.
    affinity_matrix_ : ndarray of shape (n, n)
        W with zero diagonal.
    eigenvalues_, eigenvectors_ : ndarray
        Top ``n_clusters`` eigenpairs of S, largest first.
    embedding_ : ndarray of shape (n, n_clusters)
        Row-normalised eigenvectors; ``cluster_centers_`` are the k-means centres in it.

    Examples
    --------
    >>> import numpy as np
    >>> rng = np.random.default_rng(0)
    >>> X = np.r_[rng.normal(0.0, 0.1, (20, 2)), rng.normal(3.0, 0.1, (20, 2))]
    >>> from mapping.baselines import NormalizedCutClustering
    >>> model = NormalizedCutClustering(n_clusters=2, sigma=0.5).fit(X)
    >>> np.bincount(model.labels_).tolist()
    [20, 20]
    >>> bool(model.predict([[3.0, 3.1]])[0] == model.labels_[-1])
    True

    See Also
    --------
    mapping.baselines.best_sigma_ncut : This estimator at the sigma of lowest error on labels.
    mapping.baselines.EigengapNCutClustering : Sigma chosen by the eigengap, without labels.
    mapping.baselines.SelfTuningSpectralClustering : A scale per point instead of one sigma.
    mapping.manifold.ManifoldClustering : The method this baseline is compared with.
    """

    _parameter_constraints: dict = {
        **_SpectralBase._parameter_constraints,
        "sigma": [Interval(Real, 0, None, closed="neither")],
    }

    def __init__(
        self, n_clusters: int = 2, sigma: float = 1.0, *, n_init: int = 10, random_state: int = 0
    ) -> None:
        self.n_clusters = n_clusters
        self.sigma = sigma
        self.n_init = n_init
        self.random_state = random_state

    def _affinity(self, D2: np.ndarray) -> np.ndarray:
        return np.exp(-D2 / (2.0 * float(self.sigma) ** 2))

    _affinity_new = _affinity


class SelfTuningSpectralClustering(_SpectralBase):
    """Spectral clustering with local scaling (Zelnik-Manor & Perona, NIPS 2004).

    Each point gets its own scale ``sigma_i``, the distance to its ``n_neighbors``-th nearest
    neighbour (copies of a point, a robot standing still, count as one neighbour), and
    ``W_ij = exp(-|x_i - x_j|^2 / (sigma_i sigma_j))``. The number of clusters is fixed (their
    eigenvector-rotation search for it is not used) and the rest is the NJW pipeline of
    [`NormalizedCutClustering`][mapping.baselines.spectral.NormalizedCutClustering]. A new point's
    scale is its distance to its ``n_neighbors``-th nearest training point; it is then embedded by
    the Nystrom extension.

    Parameters
    ----------
    n_clusters : int, default 2
        Number of clusters K (>= 1).
    n_neighbors : int, default 7
        Neighbour that sets the local scale (7 in the original paper); < n_samples.
    n_init : int, default 10
        k-means restarts.
    random_state : int, default 0
        Seed of the k-means initialisation.

    Attributes
    ----------
    labels_, affinity_matrix_, eigenvalues_, eigenvectors_, embedding_, cluster_centers_
        As in [`NormalizedCutClustering`][mapping.baselines.spectral.NormalizedCutClustering].
    scales_ : ndarray of shape (n,)
        The local scale sigma_i of each training point.
    min_scale_ : float
        Floor of every scale, also of new points': 1e-9 times the training data's diameter;
        every scale where the data has at most ``n_neighbors`` distinct points.

    Examples
    --------
    >>> import numpy as np
    >>> rng = np.random.default_rng(0)
    >>> X = np.r_[rng.normal(0.0, 0.1, (20, 2)), rng.normal(3.0, 0.1, (20, 2))]
    >>> from mapping.baselines import SelfTuningSpectralClustering
    >>> model = SelfTuningSpectralClustering(n_clusters=2, n_neighbors=7).fit(X)
    >>> np.bincount(model.labels_).tolist(), model.scales_.shape
    ([20, 20], (40,))

    See Also
    --------
    mapping.baselines.NormalizedCutClustering : One kernel width for every point.
    mapping.baselines.KNNSpectralClustering : Spectral clustering on a k-NN graph.
    mapping.manifold.ManifoldClustering : The method this baseline is compared with.
    """

    _parameter_constraints: dict = {
        **_SpectralBase._parameter_constraints,
        "n_neighbors": [Interval(Integral, 1, None, closed="left")],
    }

    def __init__(
        self, n_clusters: int = 2, n_neighbors: int = 7, *, n_init: int = 10, random_state: int = 0
    ) -> None:
        self.n_clusters = n_clusters
        self.n_neighbors = n_neighbors
        self.n_init = n_init
        self.random_state = random_state

    def _check_n_samples(self, n_samples: int) -> None:
        super()._check_n_samples(n_samples)
        if self.n_neighbors >= n_samples:
            raise ValueError(
                f"n_neighbors={self.n_neighbors} must be smaller than the number of samples "
                f"({n_samples})"
            )

    def _fit_sqdist(self, X: np.ndarray, D2: np.ndarray) -> SelfTuningSpectralClustering:
        # copies of one point (a robot standing still) are one neighbour of the local scales,
        # not n_neighbors of them: they would shrink sigma_i to the floor and cut them off
        self._distinct = first_copies(X)
        return super()._fit_sqdist(X, D2)

    def _local_scales(self, D2: np.ndarray, exclude_self: bool) -> np.ndarray:
        """Return each row's scale.

        The distance to its ``n_neighbors``-th nearest distinct training position (copies of a
        training point count once; a row's own copies are skipped).
        """
        kth = self.n_neighbors if exclude_self else self.n_neighbors - 1
        distinct = getattr(self, "_distinct", None)  # None: every training row is distinct
        if distinct is not None:
            D2 = D2[:, distinct]  # one column per position; a row's own comes first (~0)
            if kth >= D2.shape[1]:  # fewer distinct neighbours than n_neighbors: the floor
                return np.full(D2.shape[0], self.min_scale_)
        d = np.sqrt(np.partition(D2, kth, axis=1)[:, kth])
        # Near-duplicates can have a zero k-th neighbour distance; floor the scale at a tiny
        # fraction of the data's spread so that W stays finite and such points stay connected.
        return np.maximum(d, self.min_scale_)

    def _affinity(self, D2: np.ndarray) -> np.ndarray:
        self.min_scale_ = 1e-9 * float(np.sqrt(D2.max()))
        self.scales_ = self._local_scales(D2, exclude_self=True)
        return np.exp(-D2 / np.outer(self.scales_, self.scales_))

    def _affinity_new(self, D2_new: np.ndarray) -> np.ndarray:
        scales = self._local_scales(D2_new, exclude_self=False)
        return np.exp(-D2_new / np.outer(scales, self.scales_))
