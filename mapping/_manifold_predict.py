"""Out-of-sample signal F^j(k) of eq. 13 (Section II-F/G), exact and fast.

For cluster j with points p_j (m of them), affinity W (sigma_j, zero diagonal) and degrees d,
a new point x with affinities w to p_j gives ``p_j* = p_j + {x}`` and, with x as the last
index k, ``F^j = beta (I - alpha S^j)^-1 Y^j``. Partitioning ``I - alpha S^j`` as
``[[A, -alpha s], [-alpha s^T, 1]]`` with

* ``A = I - alpha R W R``, ``R = diag(1 / sqrt(d + w))`` (x adds w to every training degree),
* ``s = R w / sqrt(sum w)`` (x's column of S^j),

the Schur complement gives the x-row of the inverse, so toward target t

    F^j(k) = beta alpha (s^T A^-1 e_t) / (1 - alpha^2 s^T A^-1 s).

A is m x m and SPD (``|eig(R W R)| <= 1`` as a principal block of S^j), so one call costs a
distance computation, O(m^2) to form A and one small Cholesky solve with two right-hand sides.
It is exact: no approximation of the degrees. Rows of a batch are solved together with a
batched ``numpy.linalg.solve``.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from mapping._manifold_kernel import _TINY, affinity
from mapping._validation import single_threaded_blas

# Rows per batched solve: bounds the (rows, m, m) work array to ~32 MB.
_BATCH_ELEMENTS = 4_000_000


@dataclass(frozen=True)
class ClusterModel:
    """What eq. 13 needs of one cluster, precomputed at fit time.

    Attributes
    ----------
    indices : ndarray of int, shape (m,)
        Training indices of the cluster's points.
    sigma : float
        sigma_j of the affinity.
    alpha : float
        alpha of eq. 13 (0.99 in the paper).
    centre : int
        Position of the centre x_lj within ``indices``.
    mean : ndarray of shape (d,), float64
        Mean of the cluster's points; data and queries are centred on it so that squared
        distances by ``|a|^2 + |b|^2 - 2 a.b`` keep their precision (also in float32).
    data : ndarray of shape (m, d)
        The centred points, in the storage dtype (float32 halves the memory traffic that
        dominates a call for image-sized d).
    sq_norms : ndarray of shape (m,), float64
        Squared norms of the rows of ``data``.
    weights : ndarray of shape (m, m)
        W with zero diagonal.
    degrees : ndarray of shape (m,)
        Row sums of W.
    scale : float
        Divisor that makes F comparable across clusters in ``predict`` (see the docs).
    """

    indices: np.ndarray
    sigma: float
    alpha: float
    centre: int
    mean: np.ndarray
    data: np.ndarray
    sq_norms: np.ndarray
    weights: np.ndarray
    degrees: np.ndarray
    scale: float

    @classmethod
    def build(
        cls,
        X: np.ndarray,
        indices: np.ndarray,
        sq_dist: np.ndarray,
        sigma: float,
        alpha: float,
        centre: int,
        dtype: np.dtype,
    ) -> ClusterModel:
        """Precompute the cluster's state from the training data and its distance block."""
        points = X[indices]
        mean = points.mean(axis=0, dtype=np.float64)
        data = np.ascontiguousarray(points - mean, dtype=dtype)
        sq_norms = np.einsum("ij,ij->i", data, data, dtype=np.float64)
        W = affinity(sq_dist, sigma)
        np.fill_diagonal(W, 0.0)
        model = cls(
            indices=indices,
            sigma=sigma,
            alpha=alpha,
            centre=centre,
            mean=mean,
            data=data,
            sq_norms=sq_norms,
            weights=W,
            degrees=W.sum(axis=1),
            scale=1.0,
        )
        return model.with_scale(_column_scale(W, alpha, centre))

    def with_scale(self, scale: float) -> ClusterModel:
        return ClusterModel(**{**self.__dict__, "scale": scale})

    def sq_distances(self, X: np.ndarray) -> np.ndarray:
        """Squared distances (k, m) of rows of X to the cluster's points, clipped at 0."""
        Xc = np.asarray(X - self.mean, dtype=self.data.dtype)
        q = np.einsum("ij,ij->i", Xc, Xc, dtype=np.float64)
        d2 = q[:, None] + self.sq_norms[None, :] - 2.0 * (Xc @ self.data.T)
        return np.maximum(d2, 0.0)

    def signal(self, sq_dist: np.ndarray, target: int) -> np.ndarray:
        """F^j(k) of eq. 13 for each row of ``sq_dist`` (k, m) toward local index ``target``.

        Uses ``beta = 1 - alpha``. A row whose affinity to every cluster point underflows to 0
        (x is unreachable at sigma_j) gets exactly 0.
        """
        w = affinity(sq_dist, self.sigma)
        total = w.sum(axis=1)
        out = np.zeros(sq_dist.shape[0])
        rows = np.flatnonzero(total > _TINY)
        m = self.degrees.shape[0]
        step = max(1, _BATCH_ELEMENTS // (m * m))
        with single_threaded_blas():
            for start in range(0, rows.shape[0], step):
                r = rows[start : start + step]
                out[r] = self._signal_rows(w[r], total[r], target)
        return out

    def _signal_rows(self, w: np.ndarray, total: np.ndarray, target: int) -> np.ndarray:
        alpha = self.alpha
        deg = self.degrees[None, :] + w
        # A training point with no neighbour and no edge to x keeps a zero row in S^j.
        inv_sqrt = np.zeros_like(deg)
        np.divide(1.0, np.sqrt(deg), out=inv_sqrt, where=deg > _TINY)
        A = -alpha * (inv_sqrt[:, :, None] * self.weights[None] * inv_sqrt[:, None, :])
        idx = np.arange(deg.shape[1])
        A[:, idx, idx] += 1.0
        s = inv_sqrt * w / np.sqrt(total)[:, None]
        rhs = np.zeros((deg.shape[0], deg.shape[1], 2))
        rhs[:, target, 0] = 1.0
        rhs[:, :, 1] = s
        sol = np.linalg.solve(A, rhs)
        toward = np.einsum("ki,ki->k", s, sol[:, :, 0])
        self_loop = np.einsum("ki,ki->k", s, sol[:, :, 1])
        return (1.0 - alpha) * alpha * toward / (1.0 - alpha * alpha * self_loop)


def _column_scale(W: np.ndarray, alpha: float, centre: int) -> float:
    """``|beta (I - alpha S)^-1 e_c|`` on the cluster's own points: eq. 4's column norm."""
    deg = W.sum(axis=1)
    inv_sqrt = np.zeros_like(deg)
    np.divide(1.0, np.sqrt(deg), out=inv_sqrt, where=deg > _TINY)
    S = inv_sqrt[:, None] * W * inv_sqrt[None, :]
    e = np.zeros(W.shape[0])
    e[centre] = 1.0
    col = (1.0 - alpha) * np.linalg.solve(np.eye(W.shape[0]) - alpha * S, e)
    return float(np.linalg.norm(col))
