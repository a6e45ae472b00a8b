"""Similarity graphs of feature vectors (e.g. images) for the recursive min-Ncut partition.

Blanco et al. (Section I) state the observation-graph partition for any sensor whose
observations can be compared; for laser scans the weight is the sensed-space overlap
(eq. 15-18). For images there is no sensed space, so the weight is a Gaussian of the feature
distance. Like the overlap, which is zero for scans that share nothing, the graph is kept
sparse: only each vector's nearest neighbours are joined.
"""

from __future__ import annotations

import math
from numbers import Integral

import numpy as np
import scipy.sparse as sp
from numpy.typing import ArrayLike
from sklearn.utils import check_array, check_scalar

from mapping.distances import squared_distances

__all__ = ["default_n_neighbors", "knn_gaussian_affinity"]


def default_n_neighbors(n: int) -> int:
    """Return ``ceil(sqrt(n))``, at least 1 and at most ``n - 1``.

    The usual rule of thumb for kNN graphs (connected with high probability, yet local).

    Parameters
    ----------
    n : int
        Number of vectors.

    Returns
    -------
    int
        Neighbours per vector.
    """
    return max(1, min(n - 1, math.ceil(math.sqrt(n))))


def knn_gaussian_affinity(
    X: ArrayLike, n_neighbors: int | None = None
) -> tuple[sp.csr_array, float]:
    """Build a symmetric kNN graph with Gaussian weights and one global width.

    ``W_ij = exp(-|x_i - x_j|^2 / (2 sigma^2))`` when ``j`` is among the ``n_neighbors``
    nearest vectors of ``i`` or ``i`` among those of ``j``, else 0; ``W_ii = 1`` (every
    observation fully overlaps itself, as the unit diagonal of eq. 18). ``sigma`` is the median
    over all vectors of the distance to the ``n_neighbors``-th neighbour, so a typical
    neighbourhood's edge has weight ``exp(-1/2)`` whatever the feature scale.

    Parameters
    ----------
    X : array-like of shape (n, d)
        Finite feature vectors, ``n >= 2``.
    n_neighbors : int, optional
        Neighbours per vector; default ``default_n_neighbors(n)``.

    Returns
    -------
    W : scipy.sparse.csr_array of shape (n, n)
        The weights, unit diagonal.
    sigma : float
        The width used (0 when all vectors coincide; the edges then have weight 1).
    """
    X = check_array(X, dtype=np.float64, ensure_min_samples=2)
    n = X.shape[0]
    k = default_n_neighbors(n) if n_neighbors is None else n_neighbors
    k = check_scalar(k, "n_neighbors", Integral, min_val=1, max_val=n - 1)
    # exact distances by the Gram matrix: KD-trees do not help in pixel dimensions
    D2 = squared_distances(X)
    np.fill_diagonal(D2, np.inf)  # a vector is not its own neighbour
    idx = np.argsort(D2, axis=1, kind="stable")[:, :k]
    dist = np.sqrt(np.take_along_axis(D2, idx, axis=1))
    sigma = float(np.median(dist[:, -1]))
    weights = np.exp(-(dist**2) / (2.0 * sigma**2)) if sigma > 0 else np.ones_like(dist)
    rows = np.repeat(np.arange(n), k)
    W = sp.csr_array((weights.ravel(), (rows, idx.ravel())), shape=(n, n))
    W = W.maximum(W.T)  # symmetric: an edge if either end counts the other as a neighbour
    return sp.csr_array(W + sp.eye_array(n, format="csr")), sigma
