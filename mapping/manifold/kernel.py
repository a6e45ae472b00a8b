"""The manifold kernel of Grudic & Mulligan, Section II-A/B, as pure numpy.

Two ways to the same quantities:

* closed form, for tests and small problems: `normalized_affinity`, `manifold_kernel`
  (eq. 1, 3 through ``numpy.linalg.inv``), `manifold_distances` (eq. 4-6);
* the fast path, `SpectralBasis`: one symmetric eigendecomposition ``S = Q diag(lam) Q^T``
  per sigma gives ``(I - alpha S)^-1 = Q diag(1 / (1 - alpha lam)) Q^T`` for every alpha, and all
  the sums of ``D_M`` entries that eq. 9-12 need are then matrix-vector products, O(m^2) per
  alpha instead of O(m^3).

The scale ``beta`` of eq. 3 cancels in V (eq. 4) and ``D_M``; where a value of ``U`` itself is
returned we use ``beta = 1 - alpha`` so that the largest eigenvalue of U is 1 for every alpha.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy.linalg import LinAlgError, eigh

from mapping.distances import TINY as _TINY


def affinity(sq_dist: np.ndarray, sigma: float) -> np.ndarray:
    """Gaussian affinity ``W_ij = exp(-|x_i - x_j|^2 / (2 sigma^2))`` (Section II-A).

    Parameters
    ----------
    sq_dist : ndarray of shape (m, p)
        Squared Euclidean distances.
    sigma : float
        Kernel width, > 0.

    Returns
    -------
    ndarray of shape (m, p)
        The affinity; the caller zeroes the diagonal of a training block. ``exp`` underflows to
        exactly 0 silently (numpy ignores underflow), which is the intended "no edge".
    """
    return np.exp(sq_dist * (-0.5 / (sigma * sigma)))


def normalized_affinity(sq_dist: np.ndarray, sigma: float) -> np.ndarray:
    """``S = D^-1/2 W D^-1/2`` with ``W_ii = 0`` (Section II-A, Zhou et al. [18]).

    A point whose every affinity underflows (degree 0) gets a zero row and column instead of a
    division by zero; it is then its own connected component.
    """
    W = affinity(sq_dist, sigma)
    np.fill_diagonal(W, 0.0)
    deg = W.sum(axis=1)
    inv_sqrt = np.zeros_like(deg)
    np.divide(1.0, np.sqrt(deg), out=inv_sqrt, where=deg > _TINY)
    S = inv_sqrt[:, None] * W * inv_sqrt[None, :]
    # Symmetric by construction up to the last bit; make it exact for eigh.
    return 0.5 * (S + S.T)


def manifold_kernel(S: np.ndarray, alpha: float, beta: float | None = None) -> np.ndarray:
    """Closed form ``U = beta (I - alpha S)^-1`` (eq. 1, 3) through an explicit inverse.

    Used as the reference the fast path is tested against. ``beta`` defaults to ``1 - alpha``.
    """
    beta = 1.0 - alpha if beta is None else beta
    return beta * np.linalg.inv(np.eye(S.shape[0]) - alpha * S)


def manifold_distances(U: np.ndarray) -> np.ndarray:
    """``D_M = 1 - V^T V`` with V the columns of U scaled to unit length (eq. 4-6).

    U has non-negative entries, so every entry of ``D_M`` lies in [0, 1]; the result is
    clipped there against round-off and its diagonal is exactly 0.
    """
    V = U / np.linalg.norm(U, axis=0, keepdims=True)
    D = 1.0 - V.T @ V
    D = np.clip(0.5 * (D + D.T), 0.0, 1.0)
    np.fill_diagonal(D, 0.0)
    return D


def alpha_from_t(t: np.ndarray | float) -> np.ndarray | float:
    """``alpha = 1 - 10^-t``: the optimiser works in t, which spreads alpha near 1 evenly."""
    return 1.0 - 10.0 ** (-np.asarray(t, dtype=np.float64))


@dataclass(frozen=True)
class SpectralBasis:
    """Eigendecomposition of one normalised affinity S, the fast path to eq. 1-12.

    For ``g = 1 / (1 - alpha lam)`` (one column per alpha) the kernel is ``U = Q diag(g) Q^T``,
    its Gram matrix ``U^T U = Q diag(g^2) Q^T``, the column norms ``|u_i| = sqrt((Q*Q) g^2)``,
    and for any weight vector w, ``U w = Q (g * Q^T w)``. Every method below is vectorised over
    a batch of alphas (arrays of shape (m, A)).

    Attributes
    ----------
    vectors : ndarray of shape (m, m)
        Q, orthonormal eigenvectors of S.
    values : ndarray of shape (m,)
        lam, eigenvalues of S, in [-1, 1].
    sq_vectors : ndarray of shape (m, m)
        ``Q * Q``, cached because every alpha needs it for the column norms.
    """

    vectors: np.ndarray
    values: np.ndarray
    sq_vectors: np.ndarray

    @classmethod
    def from_sq_distances(cls, sq_dist: np.ndarray, sigma: float) -> SpectralBasis:
        """Build S at ``sigma`` from a square block of squared distances and decompose it."""
        S = normalized_affinity(sq_dist, sigma)
        try:
            lam, Q = eigh(S, driver="evd")
        except LinAlgError:
            # LAPACK's divide and conquer can fail to converge on near-degenerate spectra
            # (seen on inverse-range scan features); the relatively robust driver does not.
            lam, Q = eigh(S, driver="evr")
        # |lam| <= 1 in exact arithmetic; clipping keeps 1 - alpha lam > 0 for alpha < 1.
        return cls(Q, np.clip(lam, -1.0, 1.0), Q * Q)

    @property
    def size(self) -> int:
        return self.values.shape[0]

    def gains(self, alpha: np.ndarray) -> np.ndarray:
        """``g = 1 / (1 - alpha lam)``, shape (m, A), the spectrum of ``(I - alpha S)^-1``."""
        alpha = np.atleast_1d(np.asarray(alpha, dtype=np.float64))
        return 1.0 / (1.0 - self.values[:, None] * alpha[None, :])

    def column_norms(self, g: np.ndarray) -> np.ndarray:
        """``|u_i|`` of every column of U for each alpha (the divisors of eq. 4), (m, A)."""
        return np.sqrt(self.sq_vectors @ (g * g))

    def kernel_columns(self, g: np.ndarray, cols: np.ndarray) -> np.ndarray:
        """Column ``cols[a]`` of U for each alpha a, shape (m, A) (``U[:, l]`` of eq. 7)."""
        return self.vectors @ (g * self.vectors[cols].T)

    def gram_columns(self, g: np.ndarray, cols: np.ndarray) -> np.ndarray:
        """Column ``cols[a]`` of ``U^T U`` for each alpha a, shape (m, A)."""
        return self.vectors @ (g * g * self.vectors[cols].T)

    def project(self, weights: np.ndarray) -> np.ndarray:
        """``Q^T w``; for ``w = 1_A / |u|``, the eigen-coordinates of ``sum_{i in A} v_i``."""
        return self.vectors.T @ weights

    def unproject_gram(self, g: np.ndarray, coords: np.ndarray) -> np.ndarray:
        """``U^T U w`` from ``coords = Q^T w``: ``Q (g^2 * coords)``."""
        return self.vectors @ (g * g * coords)

    def quadratic(self, g: np.ndarray, c1: np.ndarray, c2: np.ndarray) -> np.ndarray:
        """``w1^T U^T U w2`` per alpha from ``c1 = Q^T w1``, ``c2 = Q^T w2``."""
        return np.einsum("ka,ka->a", g * g, c1 * c2)

    def group_gram(self, g: np.ndarray, a: int, member: np.ndarray, inv_nu: np.ndarray):
        """C x C matrix of ``(U w_b) . (U w_c)`` for ``w_b = member[:, b] / |u|`` at alpha a."""
        coords = self.project(member * inv_nu[:, None])
        return coords.T @ (coords * (g[:, a : a + 1] ** 2))

    def dense_kernel(self, alpha: float) -> np.ndarray:
        """``U = beta (I - alpha S)^-1`` with ``beta = 1 - alpha`` (eq. 3), for tests."""
        g = self.gains(alpha)[:, 0]
        return (1.0 - alpha) * (self.vectors * g) @ self.vectors.T

    def dense_distances(self, alpha: float) -> np.ndarray:
        """``D_M`` of eq. 6 at this alpha, via the basis (O(m^3); for tests and centres)."""
        return manifold_distances(self.dense_kernel(alpha))


def unit_outliers(basis, g) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Eq. 10 without forming D_M: ``O_d[i] = mean_j (1 - v_i . v_j) = 1 - v_i . (sum_j v_j) / m``.

    ``basis`` is a `SpectralBasis` or a ``mapping.manifold.lowrank_kernel.LowRankBasis`` and
    g its gains at a batch of alphas. Returns ``1 / |u_i|`` (m, A), the coordinates of
    ``w = 1 / |u|`` (for sums of unit columns) and O_d (m, A).
    """
    inv_nu = 1.0 / basis.column_norms(g)
    coords_all = basis.project(inv_nu)
    outlier = 1.0 - basis.unproject_gram(g, coords_all) * inv_nu / basis.size
    return inv_nu, coords_all, outlier


def outlier_vector(D_M: np.ndarray) -> np.ndarray:
    """Cluster-independent outlier vector ``O_d`` (eq. 10): mean of each column of ``D_M``.

    Applied to the block ``D_M(p_j, p_j)`` of one cluster it is eq. 11 (``O_d^j``), whose
    minimum is the point "most inside" the cluster, its centre.
    """
    return D_M.mean(axis=0)


def seed_pair(D_M: np.ndarray) -> tuple[int, int]:
    """Seeds ``x_l1, x_l2`` of a bisection (Section II-E, eq. 12 as corrected here).

    ``l1 = argmin O_d``, the point closest to all others. Eq. 12 as printed takes
    ``argmin O_d * D_M[:, l1]``, which is 0 at l1 itself (and then l1's nearest neighbour);
    the text says the factor is ``1 - O_d`` and that the re-weighting should "separate out
    points in the first cluster", so ``l2 = argmax (1 - O_d) * D_M[:, l1]``: a central point
    that is far from l1 along the manifold. ``docs/decisions/002-second-seed-of-eq-12.md`` has the
    evidence.
    """
    O_d = outlier_vector(D_M)
    l1 = int(np.argmin(O_d))
    l2 = int(np.argmax((1.0 - O_d) * D_M[:, l1]))
    return l1, l2
