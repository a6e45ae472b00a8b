"""One bisection (Grudic & Mulligan, Section II-C/E): maximise Omega(2), eq. 9, over (sigma, alpha).

For a node of m points and a candidate (sigma, alpha) the split is: seeds by eq. 10 and 12, the
assignment of eq. 8 (``argmax_j V[i, l_j]``), and the score of eq. 9. With the eigenbasis of S
at sigma (`SpectralBasis`) all of that is O(m^2) per alpha
and vectorised over a grid of alphas, because every mean of ``D_M`` entries is an inner product
of sums of unit columns ``v_i``:

* ``O_d = 1 - V^T (sum_j v_j) / m`` (eq. 10);
* ``E[D_M^11] = 1 - |sum_{p1} v|^2 / |p1|^2`` and ``E[D_M^12] = 1 - (sum_{p1} v).(sum_{p2} v) /
  (|p1| |p2|)``, with ``sum_A v = U (1_A / |u|)`` and ``|U w|^2 = sum_k g_k^2 (Q^T w)_k^2``.

The optimisation over (sigma, alpha) is bounded and two-dimensional, as the paper's fmincon:
a log-spaced grid over sigma times a grid over ``t = -log10(1 - alpha)`` finds the basin, then
nested bounded Brent searches (sigma outside, alpha inside, each within the neighbouring grid
cells) refine it. Omega is piecewise smooth (labels flip at discrete points), which is why a
grid comes first.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from joblib import Parallel, delayed, effective_n_jobs
from scipy.optimize import minimize_scalar

from common.blas import on_one_blas_thread
from mapping.manifold.geometry import DenseGeometry, GraphGeometry, as_geometry, sigma_grid
from mapping.manifold.kernel import SpectralBasis, alpha_from_t, unit_outliers

# Sign of eq. 9 (see docs/decisions/001-sign-of-eq-9.md): "corrected" scores E[D^12] - E[D^11]
# (between-cluster spread minus within-cluster-1 spread); "printed" is the formula as typeset.
OMEGA_SIGNS = ("corrected", "printed")
# Second-seed rule of eq. 12: "weighted" = argmax (1 - O_d) * D_M[:, l1] (the text);
# "printed" = argmin O_d * D_M[:, l1] over points other than l1 (the formula, l1 excluded).
SEED_RULES = ("weighted", "printed")
# Values of eq. 8-12 closer than this are ties, broken by the lower index. On the fast path
# they carry ~1e-13 of round-off: points of a component that the kernel barely links (small
# sigma) have equal O_d and a zero margin up to it, and a choice among them by the last bits
# made the tree depend on them (docs/decisions/007-near-tie-tolerance.md).
TIE = 1e-9
# Eigenbases a node's search keeps (by sigma, oldest dropped first).
_CACHED_BASES = 4


@dataclass(frozen=True)
class SearchSpace:
    """Bounds and resolution of the (sigma, alpha) search of one bisection.

    Parameters
    ----------
    n_sigmas, t_bounds, n_alphas, refine, refine_sigma, omega_sign, seed_rule
        The attributes below.

    Attributes
    ----------
    n_sigmas : int
        Grid points over sigma, log-spaced between the bounds of `sigma_bounds`.
    t_bounds : tuple of float
        Bounds of ``t = -log10(1 - alpha)``; (0.3, 4) is alpha in [0.5, 0.9999].
    n_alphas : int
        Grid points over t.
    refine : bool
        Run the bounded Brent refinement after the grid.
    refine_sigma : bool
        With ``refine``, refine sigma too (False: alpha only, at the grid's best sigma).
    omega_sign, seed_rule : str
        Readings of eq. 9 and eq. 12 (see `OMEGA_SIGNS`, `SEED_RULES`).
    """

    n_sigmas: int = 16
    t_bounds: tuple[float, float] = (0.3, 4.0)
    n_alphas: int = 12
    refine: bool = True
    refine_sigma: bool = True
    omega_sign: str = "corrected"
    seed_rule: str = "weighted"

    def t_grid(self) -> np.ndarray:
        """Return the grid over t.

        Returns
        -------
        ndarray of shape (n_alphas,)
            ``n_alphas`` values evenly spaced over ``t_bounds``.
        """
        return np.linspace(self.t_bounds[0], self.t_bounds[1], self.n_alphas)


@dataclass(frozen=True)
class Split:
    """The best bisection of a node: score, parameters, seeds and membership of p1.

    Parameters
    ----------
    omega : float
        Omega(2) of the split (eq. 9).
    sigma, alpha : float
        The kernel width and alpha it was found at.
    seeds : tuple of (int, int)
        l1 and l2, node-local.
    in_first : ndarray of bool, shape (m,)
        Membership of p1, the cluster seeded by l1.
    """

    omega: float
    sigma: float
    alpha: float
    seeds: tuple[int, int]
    in_first: np.ndarray


def split_scores(
    basis: SpectralBasis, alphas: np.ndarray, min_size: int, space: SearchSpace
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Return Omega(2) (eq. 9) of the seeded split for each alpha at one sigma.

    Parameters
    ----------
    basis : SpectralBasis
        Eigendecomposition of the node's S at this sigma.
    alphas : ndarray of shape (A,)
        Candidate alphas.
    min_size : int
        Q: each side of the split gets at least this many points. When eq. 8 gives a smaller
        side, the points with the largest margin ``V[i, l_1] - V[i, l_2]`` are moved so that
        every candidate is a feasible split (see the docs for why).
    space : SearchSpace
        Supplies the eq. 9 sign and the eq. 12 seed rule.

    Returns
    -------
    omega : ndarray of shape (A,)
        Omega(2) at each alpha.
    in_first : ndarray of bool, shape (m, A)
        Membership of p1, the cluster seeded by l1.
    seeds : ndarray of int, shape (2, A)
        l1 and l2 (node-local indices).
    """
    m = basis.size
    A = alphas.shape[0]
    cols = np.arange(A)
    g = basis.gains(alphas)
    inv_nu, coords_all, outlier = unit_outliers(basis, g)  # eq. 10
    l1 = _first_best(-outlier)
    # Column l1 of D_M, eq. 5
    dm_l1 = 1.0 - basis.gram_columns(g, l1) * inv_nu * inv_nu[l1, cols]
    np.clip(dm_l1, 0.0, 1.0, out=dm_l1)
    if space.seed_rule == "weighted":
        l2 = _first_best((1.0 - outlier) * dm_l1)
    else:
        weighted = outlier * dm_l1
        weighted[l1, cols] = np.inf
        l2 = _first_best(-weighted)
    # eq. 7-8: y_i = argmax_j V[i, l_j], V[i, l] = U[i, l] / |u_l|. A tie (both 0: a component
    # reached by neither seed) goes to p2, the side that "need not be on a single manifold".
    margin = (
        basis.kernel_columns(g, l1) * inv_nu[l1, cols]
        - basis.kernel_columns(g, l2) * inv_nu[l2, cols]
    )
    # Below TIE the margin is the fast path's round-off (a component neither seed reaches).
    margin[np.abs(margin) <= TIE] = 0.0
    in_first = margin > 0
    n1 = in_first.sum(axis=0)
    bad = (n1 < min_size) | (n1 > m - min_size)
    if bad.any():
        order = np.argsort(-margin[:, bad], axis=0, kind="stable")
        n1_fixed = np.clip(n1[bad], min_size, m - min_size)
        ranks = np.empty_like(order)
        np.put_along_axis(ranks, order, np.arange(m)[:, None], axis=0)
        in_first[:, bad] = ranks < n1_fixed[None, :]
        n1 = in_first.sum(axis=0)
    n2 = m - n1
    # eq. 9 from sums of unit columns: E[D^11], E[D^12]
    coords_1 = basis.project(in_first * inv_nu)
    coords_2 = coords_all - coords_1
    within = 1.0 - basis.quadratic(g, coords_1, coords_1) / (n1 * n1)
    between = 1.0 - basis.quadratic(g, coords_1, coords_2) / (n1 * n2)
    spread = between - within if space.omega_sign == "corrected" else within - between
    omega = np.minimum(n1, n2) / m * spread
    return omega, in_first, np.stack([l1, l2])


class _NodeSearch:
    """The (sigma, alpha) search of one node, with the eigenbases cached per sigma."""

    def __init__(self, geometry, min_size: int, space: SearchSpace) -> None:
        self.geometry = geometry
        self.min_size = min_size
        self.space = geometry.search_space(space)
        self._bases: dict[float, object] = {}

    def basis(self, sigma: float):
        if sigma not in self._bases:
            # Keep the few most recent: the grid visits each sigma once and the refinement
            # comes back only to its latest ones; all of them would be ~30 bases per node
            # (30 m^2 floats on the dense path, 30 m r on the sparse one).
            # The coarse search (no sigma refinement) keeps its whole grid: it is small.
            keep = _CACHED_BASES if self.space.refine_sigma else self.space.n_sigmas + 1
            if len(self._bases) >= keep:
                del self._bases[next(iter(self._bases))]
            self._bases[sigma] = self.geometry.basis(sigma)
        return self._bases[sigma]

    def scores(self, sigma: float, ts: np.ndarray):
        return split_scores(self.basis(sigma), alpha_from_t(ts), self.min_size, self.space)

    def best_alpha(self, sigma: float, t_lo: float, t_hi: float, t0: float) -> tuple[float, float]:
        """Run bounded Brent over t in [t_lo, t_hi] at fixed sigma; return (omega, t)."""
        best = (float(self.scores(sigma, np.array([t0]))[0][0]), t0)
        if t_hi - t_lo < 1e-9:
            return best
        res = minimize_scalar(
            lambda t: -self.scores(sigma, np.array([t]))[0][0],
            bounds=(t_lo, t_hi),
            method="bounded",
            options={"xatol": 0.01, "maxiter": 20},
        )
        return max(best, (float(-res.fun), float(res.x)))

    def run(self) -> Split:
        space = self.space
        lo, hi = self.geometry.sigma_bounds()
        log_sigmas, sigmas = sigma_grid(lo, hi, space.n_sigmas)
        self.geometry.prefetch(sigmas)  # a graph node: its grid's eigensolves, in parallel
        ts = space.t_grid()
        grid = np.array([self.scores(sigma, ts)[0] for sigma in sigmas])
        i, j = np.unravel_index(np.argmax(grid), grid.shape)
        log_sigma, t, omega = float(log_sigmas[i]), float(ts[j]), float(grid[i, j])
        if space.refine:
            log_sigma, t, omega = self._refine(log_sigmas, ts, i, j, omega)
        sigma = float(np.exp(log_sigma))
        omegas, in_first, seeds = self.scores(sigma, np.array([t]))
        return Split(
            omega=float(omegas[0]),
            sigma=sigma,
            alpha=float(alpha_from_t(t)),
            seeds=(int(seeds[0, 0]), int(seeds[1, 0])),
            in_first=in_first[:, 0],
        )

    def _refine(self, log_sigmas, ts, i, j, omega) -> tuple[float, float, float]:
        """Run nested bounded Brent around grid cell (i, j); keep the grid point unless beaten."""
        k = len(ts) - 1
        t_lo, t_hi = float(ts[max(j - 1, 0)]), float(ts[min(j + 1, k)])
        best = (omega, float(log_sigmas[i]), float(ts[j]))
        found: dict[float, tuple[float, float]] = {}

        def negative(log_sigma: float) -> float:
            sigma = float(np.exp(log_sigma))
            grid = self.scores(sigma, ts)[0]
            jj = int(np.argmax(grid))
            lo_t, hi_t = float(ts[max(jj - 1, 0)]), float(ts[min(jj + 1, k)])
            found[log_sigma] = self.best_alpha(sigma, lo_t, hi_t, float(ts[jj]))
            return -found[log_sigma][0]

        n = len(log_sigmas) - 1
        s_lo, s_hi = float(log_sigmas[max(i - 1, 0)]), float(log_sigmas[min(i + 1, n)])
        # Alpha first at the grid sigma (cheap: no new eigendecomposition), then sigma.
        om, t = self.best_alpha(float(np.exp(log_sigmas[i])), t_lo, t_hi, float(ts[j]))
        best = max(best, (om, float(log_sigmas[i]), t))
        if not self.space.refine_sigma:
            return best[1], best[2], best[0]
        res = minimize_scalar(
            negative, bounds=(s_lo, s_hi), method="bounded", options={"xatol": 0.02, "maxiter": 12}
        )
        om, t = found[float(res.x)] if float(res.x) in found else (-np.inf, 0.0)
        best = max(best, (om, float(res.x), t))
        return best[1], best[2], best[0]


def _first_best(values: np.ndarray) -> np.ndarray:
    """Return per column the lowest row index whose value is within `TIE` of the maximum.

    That is ``argmax`` with near-ties broken by index, not by round-off.
    """
    return np.argmax(values >= values.max(axis=0) - TIE, axis=0)


def best_split(
    sq_dist: np.ndarray | DenseGeometry | GraphGeometry, min_size: int, space: SearchSpace
) -> Split:
    """Maximise Omega(2) (eq. 9) over (sigma, alpha) for one node.

    Parameters
    ----------
    sq_dist : ndarray of shape (m, m), or a geometry of ``mapping.manifold.geometry``
        Squared distances between the node's points (the exact path), or the node as a
        geometry (dense, or a k-NN graph with the low-rank kernel).
    min_size : int
        Q; both sides of the split get at least Q points (needs m >= 2 Q).
    space : SearchSpace
        Bounds, resolution and the readings of eq. 9 and 12.

    Returns
    -------
    Split
        Omega, sigma, alpha, the seeds (node-local) and the membership of p1.
    """
    return _NodeSearch(as_geometry(sq_dist), min_size, space).run()


def best_splits(nodes: list, min_size: int, space: SearchSpace, n_jobs: int | None = None):
    """Run `best_split` on each node (a geometry), the nodes spread over ``n_jobs`` processes.

    ``n_jobs`` has joblib's meaning: None is one unless inside ``joblib.parallel_config``.
    A single node is searched here, its grid's eigensolves spread over the processes instead
    (`prefetch`): the root's bases stay with it for the combination and eq. 10. Each process
    runs BLAS on one thread, as ``fit`` does, so the splits do not depend on ``n_jobs``.

    Parameters
    ----------
    nodes : list of DenseGeometry or GraphGeometry
        The nodes to split.
    min_size : int
        Q; both sides of each split get at least Q points.
    space : SearchSpace
        Bounds, resolution and the readings of eq. 9 and 12.
    n_jobs : int, optional
        Processes.

    Returns
    -------
    list of Split
        The best split of each node, in order.
    """
    if len(nodes) < 2 or effective_n_jobs(n_jobs) < 2:
        return [best_split(node, min_size, space) for node in nodes]
    return Parallel(n_jobs=n_jobs)(
        delayed(on_one_blas_thread)(best_split, node.portable(), min_size, space) for node in nodes
    )
