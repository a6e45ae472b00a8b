"""The two solvers of eq. 13 (Grudic & Mulligan, Section II-F/G) behind ``ClusterModel.signal``.

`sparse_signal` is the Woodbury form on the support of the query's affinities derived in
`mapping.manifold.cluster_model`'s docstring (an |S| x |S| system per row, exact);
`dense_signal` solves the m x m system A of the Schur complement directly, for the rare
cluster whose fit-time inverse H does not exist. Both return ``F^j(k)`` with
``beta = 1 - alpha`` and exactly 0 for a row whose affinities all underflow.
"""

from __future__ import annotations

from contextlib import nullcontext

import numpy as np

from common.blas import single_threaded_blas
from mapping.distances import TINY as _TINY

# Rows per batched solve: bounds the (rows, m, m) work array to ~32 MB.
_BATCH_ELEMENTS = 4_000_000
# Systems of at least this many rows are solved on one BLAS thread. OpenBLAS threads an LU
# only from 100 rows on (its dgesv, interface/lapack/gesv.c: one thread while m^2 < 10,000,
# whatever the setting), and on a busy machine a second thread only spins; below the bound,
# setting the threads and back costs more than the solve (~0.06 ms of a 0.5 ms ``predict``
# of one view).
_THREADED_SOLVE = 64


def dense_signal(
    weights: np.ndarray, degrees: np.ndarray, alpha: float, w: np.ndarray, target: int
) -> np.ndarray:
    """Return eq. 13 by the m x m solve of A per row, for a cluster with a point of degree 0.

    Such a cluster has no H.

    Parameters
    ----------
    weights : ndarray of shape (m, m)
        W, zero diagonal.
    degrees : ndarray of shape (m,)
        d, the row sums of W.
    alpha : float
        alpha of eq. 13.
    w : ndarray of shape (k, m)
        Affinities of the queries to the cluster's points.
    target : int
        Local index of the target point.

    Returns
    -------
    ndarray of shape (k,)
        F^j(k) of each query; 0 where every affinity is 0.
    """
    total = w.sum(axis=1)
    out = np.zeros(w.shape[0])
    rows = np.flatnonzero(total > _TINY)
    m = degrees.shape[0]
    step = max(1, _BATCH_ELEMENTS // (m * m))
    for start in range(0, rows.shape[0], step):
        r = rows[start : start + step]
        deg = degrees[None, :] + w[r]
        # A training point with no neighbour and no edge to x keeps a zero row in S^j.
        inv_sqrt = np.zeros_like(deg)
        np.divide(1.0, np.sqrt(deg), out=inv_sqrt, where=deg > _TINY)
        A = -alpha * (inv_sqrt[:, :, None] * weights[None] * inv_sqrt[:, None, :])
        A.reshape(len(r), m * m)[:, :: m + 1] += 1.0
        s = inv_sqrt * w[r] / np.sqrt(total[r])[:, None]
        rhs = np.zeros((len(r), m, 2))
        rhs[:, target, 0] = 1.0
        rhs[:, :, 1] = s
        with single_threaded_blas():
            sol = np.linalg.solve(A, rhs)
        toward = np.einsum("ki,ki->k", s, sol[:, :, 0])
        self_loop = np.einsum("ki,ki->k", s, sol[:, :, 1])
        out[r] = (1.0 - alpha) * alpha * toward / (1.0 - alpha * alpha * self_loop)
    return out


def sparse_signal(
    inverse: np.ndarray,
    degrees: np.ndarray,
    w: np.ndarray,
    cluster: np.ndarray,
    target: np.ndarray,
    alpha: np.ndarray,
) -> np.ndarray:
    """Return eq. 13 by Woodbury on the support S of w, for B (row, cluster) pairs.

    Parameters
    ----------
    inverse : ndarray of shape (K, m, m)
        H of each cluster (padding 0).
    degrees : ndarray of shape (K, m)
        d of each cluster (padding 1).
    w : ndarray of shape (B, m)
        Affinities of each row (padding 0).
    cluster, target : ndarray of int, shape (B,)
        The cluster and local target of each row.
    alpha : ndarray of shape (B,)
        The alpha of each row.

    Returns
    -------
    ndarray of shape (B,)
        F^j(k) of each row; 0 where every affinity is 0.
    """
    total = w.sum(axis=1)
    out = np.zeros(w.shape[0])
    reach = total > _TINY
    support = w > 0.0
    support &= reach[:, None]
    size = support.sum(axis=1)  # count_nonzero along an axis takes twice as long
    # Rows sorted by |S| and cut into blocks each padded to its own largest |S|: one row
    # near many points does not make every row of a batch pay for an m x m system.
    order = np.argsort(size, kind="stable")[w.shape[0] - np.count_nonzero(reach) :]
    if order.size == 0:
        return out
    step = max(1, _BATCH_ELEMENTS // int(size[order[-1]]) ** 2)
    for start in range(0, order.size, step):
        rows = order[start : start + step]
        r = int(size[rows[-1]])
        # the support's positions first (stable: ascending), then filler with g = 0
        pos = np.argsort(~support[rows], axis=1, kind="stable")[:, :r]
        rr = rows[:, None]
        ws = w[rr, pos]
        if size[rows[0]] < r:
            ws[np.arange(r)[None, :] >= size[rr]] = 0.0
        root = np.sqrt(ws)
        c = cluster[rr]
        g = root / np.sqrt(degrees[c, pos])
        system = inverse[c[:, :, None], pos[:, :, None], pos[:, None, :]]
        system *= g[:, :, None] * g[:, None, :]
        system.reshape(len(rows), r * r)[:, :: r + 1] += 1.0
        with single_threaded_blas() if r >= _THREADED_SOLVE else nullcontext():
            v = np.linalg.solve(system, root[:, :, None])[:, :, 0]
        t = target[rr]
        toward = np.einsum("kr,kr,kr->k", inverse[c, t, pos], g, v)
        d_t, total_r, t = degrees[c[:, 0], t[:, 0]], total[rows], t[:, 0]
        toward *= np.sqrt((d_t + w[rows, t]) / (d_t * total_r))
        a = alpha[rows]
        gap = np.einsum("kr,kr->k", root, v) / total_r  # 1 - s^T A^-1 s
        out[rows] = (1.0 - a) * a * toward / (1.0 - a * a + a * a * gap)
    return out
