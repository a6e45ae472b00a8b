"""The manifold kernel of eq. 1-12 on a sparse k-nearest-neighbour graph, from a few eigenpairs.

For large nodes `LowRankBasis` stands in for `SpectralBasis`. The affinity W keeps only the
edges of a symmetrised k-nearest-neighbour graph
(every other affinity is set to 0, as the Gaussian's own underflow does far away), S is sparse,
and per connected component c only the top k_c eigenpairs of S are computed (ARPACK in
shift-invert mode about 1, which converges in a few iterations where plain Lanczos crawls: the
top of the spectrum of a chain of views is tightly clustered). The rest of the spectrum of each
component enters through its mean ``mu_c`` (known from the trace: ``tr S_c = 0`` as
``W_ii = 0``), i.e. ``(I - alpha S)^-1`` is replaced by

    U = Q diag(g - e_col) Q^T + diag(e),   g = 1 / (1 - alpha lam),  e = 1 / (1 - alpha mu_c),

which is exact on the span of Q and on components solved in full (small ones and single points,
where ``U = 1``), and replaces the gains of the left-out eigenvalues by that of their mean. Every
quantity of eq. 4-12 follows in O(m r) per alpha: ``U^2 = Q diag(g^2 - e_col^2) Q^T + diag(e^2)``
(cross terms vanish because e is constant on a component and Q's columns live on one).
Memory is O(m r) plus the graph's O(m k); nothing is m x m.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import scipy.sparse as sp
from scipy.linalg import eigh
from scipy.sparse.csgraph import connected_components
from scipy.sparse.linalg import ArpackError, ArpackNoConvergence, eigsh

from mapping.distances import TINY

# Shift of the shift-invert eigensolver: just above the largest eigenvalue of S (1), so that
# S - shift I stays non-singular also on a component whose top eigenvalue is exactly 1.
_SHIFT = 1.0 + 1e-3
# Components up to this size are decomposed densely when ARPACK does not converge.
_DENSE_FALLBACK = 3000
# Above this many groups, `LowRankBasis.group_gram` uses sparse membership products.
_FEW_GROUPS = 16


def _top_eigenpairs(block: sp.csr_matrix, k: int) -> tuple[np.ndarray, np.ndarray]:
    """Return the k largest eigenpairs of a symmetric sparse block (one component of S).

    ARPACK in shift-invert mode about 1; a Krylov space of k + 16 (not ARPACK's default
    2 k + 1, nor 1.5 k): at k = 64 on a 5000-point 10-NN graph 1.3 s against 2.7 s for 1.5 k
    and 6.7 s for 2 k, the same eigenpairs (ARPACK's dense work grows with ncv faster than the
    extra restarts of a smaller space cost). The start vector is fixed (no
    hidden randomness) and deliberately not ``sqrt(degrees)``, the top eigenvector itself,
    from which the Krylov space would not grow. If ARPACK does not converge, a block small
    enough is decomposed densely, a larger one keeps the pairs that did converge. Where
    ARPACK cannot restart at all ("error 3: no shifts could be applied": a component that is
    nearly many components at a small sigma, with more than k eigenvalues within 1e-6 of 1;
    seen in a 675-point node of 1350 pooled image frames), the solve is repeated once with
    twice the space, then treated as not converging.
    """
    size = block.shape[0]
    v0 = 1.5 + np.cos(0.618 * np.arange(size))
    A = block.tocsc()
    for ncv in (k + 16, 2 * (k + 16)):
        try:
            return eigsh(A, k=k, sigma=_SHIFT, which="LM", tol=1e-8, v0=v0, ncv=min(size, ncv))
        except ArpackNoConvergence as err:
            failure = err
            break  # a larger space is for a failed restart, not slow convergence
        except ArpackError as err:
            failure = err
    if size <= _DENSE_FALLBACK:
        lam, q = eigh(block.toarray())
        return lam[-k:], q[:, -k:]
    found = getattr(failure, "eigenvalues", np.zeros(0))
    if not found.size:
        raise RuntimeError(f"ARPACK found no eigenpair of a {size}-point component") from failure
    return found, failure.eigenvectors


@dataclass(frozen=True)
class LowRankGains:
    """Gains at a batch of A alphas.

    Parameters
    ----------
    top : ndarray of shape (r, A)
        Gains of the kept eigenpairs.
    col_rest : ndarray of shape (r, A)
        The rest-gain of each column's component.
    point_rest : ndarray of shape (m, A)
        The rest-gain of each point's component.
    """

    top: np.ndarray
    col_rest: np.ndarray
    point_rest: np.ndarray


@dataclass(frozen=True)
class LowRankBasis:
    """Kept eigenpairs of a sparse S and the mean of the left-out eigenvalues per component.

    Same methods as `SpectralBasis`, so that
    `mapping.manifold.split.split_scores` runs on either; "coordinates" of a weight
    vector w are ``[Q^T w; w]`` (shape (r + m, A)), linear in w as the split needs.

    Parameters
    ----------
    vectors : ndarray of shape (m, r)
        Kept eigenvectors.
    values : ndarray of shape (r,)
        Their eigenvalues.
    col_comp, point_comp : ndarray of int
        Component of each column and of each point.
    rest_means : ndarray of shape (C,)
        Mean of each component's left-out eigenvalues.

    Attributes
    ----------
    vectors : ndarray of shape (m, r)
        Kept orthonormal eigenvectors; each is supported on one component.
    values : ndarray of shape (r,)
        Their eigenvalues.
    col_comp, point_comp : ndarray of int
        Component of each column and of each point.
    rest_means : ndarray of shape (C,)
        Mean of each component's left-out eigenvalues (0 where none is left out).
    """

    vectors: np.ndarray
    values: np.ndarray
    col_comp: np.ndarray
    point_comp: np.ndarray
    rest_means: np.ndarray

    @classmethod
    def from_edges(cls, edges: sp.csr_matrix, sigma: float, rank: int) -> LowRankBasis:
        """Build S at ``sigma`` on the graph ``edges`` and keep its top eigenpairs.

        At most ``2 rank`` columns in all. Components are taken largest first; one that fits
        in what is left of the budget is decomposed in full (dense), a larger one gets
        ``min(rank, budget)`` eigenpairs, and once the budget is spent a component is
        represented by its mean eigenvalue alone.

        Parameters
        ----------
        edges : scipy.sparse.csr_matrix of shape (m, m)
            Symmetric squared distances of the graph's edges, explicit zeros for duplicates.
        sigma : float
            Kernel width.
        rank : int
            Eigenpairs per large component; the budget is twice this.

        Returns
        -------
        LowRankBasis
            The kept eigenpairs and the components' rest means.
        """
        m = edges.shape[0]
        W = edges.copy()
        W.data = np.exp(W.data * (-0.5 / (sigma * sigma)))
        W.eliminate_zeros()  # underflow: no edge at this sigma
        deg = np.asarray(W.sum(axis=1)).ravel()
        inv_sqrt = np.zeros(m)
        np.divide(1.0, np.sqrt(deg), out=inv_sqrt, where=deg > TINY)
        S = sp.csr_matrix(W.multiply(inv_sqrt[:, None]).multiply(inv_sqrt[None, :]))
        S = (0.5 * (S + S.T)).tocsr()
        n_comp, labels = connected_components(W, directed=False)
        sizes = np.bincount(labels, minlength=n_comp)
        budget = 2 * rank
        vecs, vals, cols = [], [], []
        rest = np.zeros(n_comp)
        for c in np.argsort(-sizes, kind="stable"):
            size = int(sizes[c])
            if size < 2 or budget <= 0:
                continue  # a single point has S = 0: its one eigenvalue is the mean, 0
            members = np.flatnonzero(labels == c)
            block = S[members][:, members]
            if size <= budget:
                lam, q = eigh(block.toarray())
            else:
                k = min(rank, budget)
                lam, q = _top_eigenpairs(block, k)
                rest[c] = -lam.sum() / (size - lam.shape[0])
            full = np.zeros((m, lam.shape[0]))
            full[members] = q
            vecs.append(full)
            vals.append(np.clip(lam, -1.0, 1.0))
            cols.append(np.full(lam.shape[0], c))
            budget -= lam.shape[0]
        if not vecs:
            vecs, vals, cols = [np.zeros((m, 0))], [np.zeros(0)], [np.zeros(0, dtype=int)]
        return cls(np.hstack(vecs), np.concatenate(vals), np.concatenate(cols), labels, rest)

    @property
    def size(self) -> int:
        """Number of points m."""
        return self.point_comp.shape[0]

    def gains(self, alpha: np.ndarray) -> LowRankGains:
        """Return the gains of the kept eigenpairs and of the components' rests.

        Parameters
        ----------
        alpha : float or ndarray of shape (A,)
            The alphas.

        Returns
        -------
        LowRankGains
            ``1 / (1 - alpha lam)`` and ``1 / (1 - alpha mu_c)`` per column and per point.
        """
        alpha = np.atleast_1d(np.asarray(alpha, dtype=np.float64))
        rest = 1.0 / (1.0 - self.rest_means[:, None] * alpha[None, :])
        return LowRankGains(
            1.0 / (1.0 - self.values[:, None] * alpha[None, :]),
            rest[self.col_comp],
            rest[self.point_comp],
        )

    @staticmethod
    def _square_gains(g: LowRankGains) -> np.ndarray:
        """Return the spectrum of ``U^2`` on the kept columns, less the rest part in diag(e^2)."""
        return g.top * g.top - g.col_rest * g.col_rest

    def column_norms(self, g: LowRankGains) -> np.ndarray:
        """Return ``|u_i|`` of every column of U for each alpha.

        Parameters
        ----------
        g : LowRankGains
            Gains.

        Returns
        -------
        ndarray of shape (m, A)
            The column norms.
        """
        sq = (self.vectors * self.vectors) @ self._square_gains(g) + g.point_rest**2
        return np.sqrt(np.maximum(sq, 0.0))

    def _diagonal_term(self, out: np.ndarray, diag: np.ndarray, cols: np.ndarray) -> np.ndarray:
        a = np.arange(cols.shape[0])
        out[cols, a] += diag[cols, a]
        return out

    def kernel_columns(self, g: LowRankGains, cols: np.ndarray) -> np.ndarray:
        """Return column ``cols[a]`` of U for each alpha a.

        Parameters
        ----------
        g : LowRankGains
            Gains.
        cols : ndarray of int, shape (A,)
            The column for each alpha.

        Returns
        -------
        ndarray of shape (m, A)
            The columns.
        """
        out = self.vectors @ ((g.top - g.col_rest) * self.vectors[cols].T)
        return self._diagonal_term(out, g.point_rest, cols)

    def gram_columns(self, g: LowRankGains, cols: np.ndarray) -> np.ndarray:
        """Return column ``cols[a]`` of ``U^2`` for each alpha a.

        Parameters
        ----------
        g : LowRankGains
            Gains.
        cols : ndarray of int, shape (A,)
            The column for each alpha.

        Returns
        -------
        ndarray of shape (m, A)
            The columns.
        """
        out = self.vectors @ (self._square_gains(g) * self.vectors[cols].T)
        return self._diagonal_term(out, g.point_rest**2, cols)

    def project(self, weights: np.ndarray) -> np.ndarray:
        """Return the coordinates ``[Q^T w; w]`` of the weights.

        Parameters
        ----------
        weights : ndarray of shape (m, A)
            w.

        Returns
        -------
        ndarray of shape (r + m, A)
            The coordinates.
        """
        return np.vstack([self.vectors.T @ weights, weights])

    def unproject_gram(self, g: LowRankGains, coords: np.ndarray) -> np.ndarray:
        """Return ``U^2 w`` from the coordinates ``[Q^T w; w]``.

        Parameters
        ----------
        g : LowRankGains
            Gains.
        coords : ndarray of shape (r + m, A)
            The coordinates of w.

        Returns
        -------
        ndarray of shape (m, A)
            ``U^2 w`` for each alpha.
        """
        r = self.values.shape[0]
        return self.vectors @ (self._square_gains(g) * coords[:r]) + g.point_rest**2 * coords[r:]

    def quadratic(self, g: LowRankGains, c1: np.ndarray, c2: np.ndarray) -> np.ndarray:
        """Return ``w1^T U^2 w2`` per alpha from coordinates ``[Q^T w; w]``.

        Parameters
        ----------
        g : LowRankGains
            Gains.
        c1, c2 : ndarray of shape (r + m, A)
            The coordinates of w1 and w2.

        Returns
        -------
        ndarray of shape (A,)
            The quadratic form at each alpha.
        """
        r = self.values.shape[0]
        top = np.einsum("ka,ka->a", self._square_gains(g), c1[:r] * c2[:r])
        return top + np.einsum("ka,ka->a", g.point_rest**2, c1[r:] * c2[r:])

    def group_gram(self, g: LowRankGains, a: int, member: np.ndarray, inv_nu: np.ndarray):
        """Return the C x C matrix of ``(U w_b) . (U w_c)`` for ``w_b = member[:, b] / |u|``.

        Many groups (the leaves of a large fit) go through a sparse membership matrix, O(m r)
        for one group per point instead of O(m r C); ``member`` may be given sparse.

        Parameters
        ----------
        g : LowRankGains
            Gains.
        a : int
            The alpha's column of the gains.
        member : ndarray or sparse matrix of shape (m, C)
            Membership of each point in each of the C groups.
        inv_nu : ndarray of shape (m,)
            ``1 / |u_i|`` at that alpha.

        Returns
        -------
        ndarray of shape (C, C)
            The Gram matrix of the groups' summed unit columns.
        """
        if sp.issparse(member):
            weights = sp.csr_matrix(member.multiply(inv_nu[:, None]))
            rest_w = sp.csr_matrix(weights.multiply((g.point_rest[:, a] ** 2)[:, None]))
        else:
            weights = member * inv_nu[:, None]
            rest_w = weights * (g.point_rest[:, a] ** 2)[:, None]
        if not sp.issparse(member) and member.shape[1] > _FEW_GROUPS:
            weights, rest_w = sp.csr_matrix(weights), sp.csr_matrix(rest_w)
        top = np.asarray((weights.T @ self.vectors).T)  # (r, C)
        rest = weights.T @ rest_w
        rest = rest.toarray() if sp.issparse(rest) else rest
        return top.T @ (top * self._square_gains(g)[:, a : a + 1]) + rest
