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
    """Return the Gaussian affinity ``W_ij = exp(-|x_i - x_j|^2 / (2 sigma^2))`` (Section II-A).

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
    """Return ``S = D^-1/2 W D^-1/2`` with ``W_ii = 0`` (Section II-A, Zhou et al. [18]).

    A point whose every affinity underflows (degree 0) gets a zero row and column instead of a
    division by zero; it is then its own connected component.

    Parameters
    ----------
    sq_dist : ndarray of shape (m, m)
        Squared distances of the points.
    sigma : float
        Kernel width, > 0.

    Returns
    -------
    ndarray of shape (m, m)
        S, exactly symmetric.
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
    """Return the closed form ``U = beta (I - alpha S)^-1`` (eq. 1, 3) by an explicit inverse.

    Used as the reference the fast path is tested against.

    Parameters
    ----------
    S : ndarray of shape (m, m)
        Normalised affinity.
    alpha : float
        alpha, in (0, 1).
    beta : float, optional
        Scale; default ``1 - alpha``.

    Returns
    -------
    ndarray of shape (m, m)
        U.
    """
    beta = 1.0 - alpha if beta is None else beta
    return beta * np.linalg.inv(np.eye(S.shape[0]) - alpha * S)


def manifold_distances(U: np.ndarray) -> np.ndarray:
    """Return ``D_M = 1 - V^T V`` with V the columns of U scaled to unit length (eq. 4-6).

    U has non-negative entries, so every entry of ``D_M`` lies in [0, 1]; the result is
    clipped there against round-off and its diagonal is exactly 0.

    Parameters
    ----------
    U : ndarray of shape (m, m)
        The manifold kernel.

    Returns
    -------
    ndarray of shape (m, m)
        D_M, symmetric.
    """
    V = U / np.linalg.norm(U, axis=0, keepdims=True)
    D = 1.0 - V.T @ V
    D = np.clip(0.5 * (D + D.T), 0.0, 1.0)
    np.fill_diagonal(D, 0.0)
    return D


def alpha_from_t(t: np.ndarray | float) -> np.ndarray | float:
    """Return ``alpha = 1 - 10^-t``: the optimiser works in t, which spreads alpha near 1 evenly.

    Parameters
    ----------
    t : float or ndarray
        Exponent(s).

    Returns
    -------
    float or ndarray
        alpha for each t.
    """
    return 1.0 - 10.0 ** (-np.asarray(t, dtype=np.float64))


@dataclass(frozen=True)
class SpectralBasis:
    """Eigendecomposition of one normalised affinity S, the fast path to eq. 1-12.

    For ``g = 1 / (1 - alpha lam)`` (one column per alpha) the kernel is ``U = Q diag(g) Q^T``,
    its Gram matrix ``U^T U = Q diag(g^2) Q^T``, the column norms ``|u_i| = sqrt((Q*Q) g^2)``,
    and for any weight vector w, ``U w = Q (g * Q^T w)``. Every method below is vectorised over
    a batch of alphas (arrays of shape (m, A)).

    Parameters
    ----------
    vectors : ndarray of shape (m, m)
        Q.
    values : ndarray of shape (m,)
        lam.
    sq_vectors : ndarray of shape (m, m)
        ``Q * Q``.

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
        """Build S at ``sigma`` from a square block of squared distances and decompose it.

        Parameters
        ----------
        sq_dist : ndarray of shape (m, m)
            Squared distances of the points.
        sigma : float
            Kernel width.

        Returns
        -------
        SpectralBasis
            The eigenbasis of S, eigenvalues clipped to [-1, 1].
        """
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
        """Number of points m."""
        return self.values.shape[0]

    def gains(self, alpha: np.ndarray) -> np.ndarray:
        """Return ``g = 1 / (1 - alpha lam)``, the spectrum of ``(I - alpha S)^-1``.

        Parameters
        ----------
        alpha : float or ndarray of shape (A,)
            The alphas.

        Returns
        -------
        ndarray of shape (m, A)
            One column of gains per alpha.
        """
        alpha = np.atleast_1d(np.asarray(alpha, dtype=np.float64))
        return 1.0 / (1.0 - self.values[:, None] * alpha[None, :])

    def column_norms(self, g: np.ndarray) -> np.ndarray:
        """Return ``|u_i|`` of every column of U for each alpha (the divisors of eq. 4).

        Parameters
        ----------
        g : ndarray of shape (m, A)
            Gains.

        Returns
        -------
        ndarray of shape (m, A)
            The column norms.
        """
        return np.sqrt(self.sq_vectors @ (g * g))

    def kernel_columns(self, g: np.ndarray, cols: np.ndarray) -> np.ndarray:
        """Return column ``cols[a]`` of U for each alpha a (``U[:, l]`` of eq. 7).

        Parameters
        ----------
        g : ndarray of shape (m, A)
            Gains.
        cols : ndarray of int, shape (A,)
            The column for each alpha.

        Returns
        -------
        ndarray of shape (m, A)
            The columns, without the scale beta.
        """
        return self.vectors @ (g * self.vectors[cols].T)

    def gram_columns(self, g: np.ndarray, cols: np.ndarray) -> np.ndarray:
        """Return column ``cols[a]`` of ``U^T U`` for each alpha a.

        Parameters
        ----------
        g : ndarray of shape (m, A)
            Gains.
        cols : ndarray of int, shape (A,)
            The column for each alpha.

        Returns
        -------
        ndarray of shape (m, A)
            The columns.
        """
        return self.vectors @ (g * g * self.vectors[cols].T)

    def project(self, weights: np.ndarray) -> np.ndarray:
        """Return ``Q^T w``; for ``w = 1_A / |u|``, the eigen-coordinates of ``sum_{i in A} v_i``.

        Parameters
        ----------
        weights : ndarray of shape (m,) or (m, A)
            w.

        Returns
        -------
        ndarray of shape (m,) or (m, A)
            The coordinates.
        """
        return self.vectors.T @ weights

    def unproject_gram(self, g: np.ndarray, coords: np.ndarray) -> np.ndarray:
        """Return ``U^T U w`` from ``coords = Q^T w``: ``Q (g^2 * coords)``.

        Parameters
        ----------
        g : ndarray of shape (m, A)
            Gains.
        coords : ndarray of shape (m, A)
            ``Q^T w``.

        Returns
        -------
        ndarray of shape (m, A)
            ``U^T U w`` for each alpha.
        """
        return self.vectors @ (g * g * coords)

    def quadratic(self, g: np.ndarray, c1: np.ndarray, c2: np.ndarray) -> np.ndarray:
        """Return ``w1^T U^T U w2`` per alpha from ``c1 = Q^T w1``, ``c2 = Q^T w2``.

        Parameters
        ----------
        g : ndarray of shape (m, A)
            Gains.
        c1, c2 : ndarray of shape (m, A)
            The coordinates of w1 and w2.

        Returns
        -------
        ndarray of shape (A,)
            The quadratic form at each alpha.
        """
        return np.einsum("ka,ka->a", g * g, c1 * c2)

    def group_gram(self, g: np.ndarray, a: int, member: np.ndarray, inv_nu: np.ndarray):
        """Return the C x C matrix of ``(U w_b) . (U w_c)`` for ``w_b = member[:, b] / |u|``.

        Parameters
        ----------
        g : ndarray of shape (m, A)
            Gains.
        a : int
            The alpha's column of ``g``.
        member : ndarray of shape (m, C)
            Membership of each point in each of the C groups.
        inv_nu : ndarray of shape (m,)
            ``1 / |u_i|`` at that alpha.

        Returns
        -------
        ndarray of shape (C, C)
            The Gram matrix of the groups' summed unit columns.
        """
        coords = self.project(member * inv_nu[:, None])
        return coords.T @ (coords * (g[:, a : a + 1] ** 2))

    def dense_kernel(self, alpha: float) -> np.ndarray:
        """Return ``U = beta (I - alpha S)^-1`` with ``beta = 1 - alpha`` (eq. 3), for tests.

        Parameters
        ----------
        alpha : float
            alpha.

        Returns
        -------
        ndarray of shape (m, m)
            U.
        """
        g = self.gains(alpha)[:, 0]
        return (1.0 - alpha) * (self.vectors * g) @ self.vectors.T

    def dense_distances(self, alpha: float) -> np.ndarray:
        """Return ``D_M`` of eq. 6 at this alpha, via the basis (O(m^3); for tests and centres).

        Parameters
        ----------
        alpha : float
            alpha.

        Returns
        -------
        ndarray of shape (m, m)
            D_M.
        """
        return manifold_distances(self.dense_kernel(alpha))


def unit_outliers(basis, g) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Return eq. 10 without forming D_M, and the quantities it is computed from.

    ``O_d[i] = mean_j (1 - v_i . v_j) = 1 - v_i . (sum_j v_j) / m``.

    Parameters
    ----------
    basis : SpectralBasis or LowRankBasis
        The eigenbasis (``mapping.manifold.lowrank_kernel.LowRankBasis`` on the graph path).
    g : ndarray of shape (m, A)
        Its gains at a batch of alphas.

    Returns
    -------
    inv_nu : ndarray of shape (m, A)
        ``1 / |u_i|``.
    coords_all : ndarray
        The coordinates of ``w = 1 / |u|`` (for sums of unit columns).
    outlier : ndarray of shape (m, A)
        O_d.
    """
    inv_nu = 1.0 / basis.column_norms(g)
    coords_all = basis.project(inv_nu)
    outlier = 1.0 - basis.unproject_gram(g, coords_all) * inv_nu / basis.size
    return inv_nu, coords_all, outlier


def outlier_vector(D_M: np.ndarray) -> np.ndarray:
    """Return the cluster-independent outlier vector ``O_d`` (eq. 10): each column's mean of D_M.

    Applied to the block ``D_M(p_j, p_j)`` of one cluster it is eq. 11 (``O_d^j``), whose
    minimum is the point "most inside" the cluster, its centre.

    Parameters
    ----------
    D_M : ndarray of shape (m, m)
        Manifold distances.

    Returns
    -------
    ndarray of shape (m,)
        O_d.
    """
    return D_M.mean(axis=0)


def seed_pair(D_M: np.ndarray) -> tuple[int, int]:
    """Return the seeds ``x_l1, x_l2`` of a bisection (Section II-E, eq. 12 as corrected here).

    ``l1 = argmin O_d``, the point closest to all others. Eq. 12 as printed takes
    ``argmin O_d * D_M[:, l1]``, which is 0 at l1 itself (and then l1's nearest neighbour);
    the text says the factor is ``1 - O_d`` and that the re-weighting should "separate out
    points in the first cluster", so ``l2 = argmax (1 - O_d) * D_M[:, l1]``: a central point
    that is far from l1 along the manifold. ``docs/decisions/002-second-seed-of-eq-12.md`` has the
    evidence.

    Parameters
    ----------
    D_M : ndarray of shape (m, m)
        Manifold distances.

    Returns
    -------
    l1, l2 : int
        The two seeds.
    """
    O_d = outlier_vector(D_M)
    l1 = int(np.argmin(O_d))
    l2 = int(np.argmax((1.0 - O_d) * D_M[:, l1]))
    return l1, l2
