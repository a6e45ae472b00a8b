"""What the bisection and the combination need to know about a set of points, two ways.

`DenseGeometry` holds the node's full squared-distance matrix and gives the exact
eigenbasis of S (`SpectralBasis`): the reference path, and the
one used for every node of a small fit. `GraphGeometry` holds the training points and a
symmetrised k-nearest-neighbour graph of them and gives the low-rank basis of
`mapping.manifold.lowrank_kernel`; nothing in it is m x m. A node of it with at most
``dense_below`` points turns into a `DenseGeometry` of its own distances (computed then,
O(m^2 d) for small m), so the deep, small nodes of a large fit are exact.
"""

from __future__ import annotations

from dataclasses import replace

import numpy as np
import scipy.sparse as sp
from joblib import Parallel, delayed, effective_n_jobs

from common.blas import on_one_blas_thread
from mapping.distances import squared_distances
from mapping.manifold.kernel import SpectralBasis, outlier_vector, unit_outliers
from mapping.manifold.lowrank_kernel import LowRankBasis
from mapping.validation import check_span

# Values of ManifoldClustering's ``kernel``; "auto" takes the k-NN graph above this many
# samples, so every fit of up to 1000 points (the paper's sizes, all earlier tables and tests)
# stays on the exact dense path.
KERNELS = ("auto", "dense", "sparse")
AUTO_SPARSE_ABOVE = 1000
# Candidates per point beyond k taken from the float32 product and re-ranked in float64.
_KNN_SPARE = 8
# Elements of one block of the k-NN distance matrix (~32 MB of float32 and its argpartition).
_KNN_ELEMENTS = 4_000_000


def coarse_space(space):
    """Return the search space of the scalable path: alpha refined by Brent, sigma not.

    The scalable path is the graph and the dense sub-nodes of a graph fit; it searches the
    same ``n_sigmas`` grid as the exact path.

    Each sigma costs one eigensolve, alpha none (eigenpairs are reused across alpha), so the
    refinement in sigma (about 12 more eigensolves per split) is what is left out. The grid
    is the full 16 sigmas, not 6: it makes purer leaves (on 100 test image seeds the tree's
    bound 6.0 -> 4.4 %, test error 10.7 -> 9.1 %) at about 1.7x the fit's time (docs:
    "Scaling", "The split search's grid").

    Parameters
    ----------
    space : SearchSpace
        The exact path's search space.

    Returns
    -------
    SearchSpace
        ``space`` without the refinement in sigma.
    """
    return replace(space, refine_sigma=False)


def sigma_grid(lo: float, hi: float, n_sigmas: int) -> tuple[np.ndarray, list[float]]:
    """Return the split search's sigmas: ``n_sigmas`` log-spaced from ``lo`` to ``hi``.

    One function for every caller: the graph path's cached eigenbases are keyed by these
    floats, so the split, the combination and eq. 10 must build them bit for bit alike.

    Parameters
    ----------
    lo, hi : float
        The smallest and largest sigma, positive.
    n_sigmas : int
        Number of sigmas.

    Returns
    -------
    logs : ndarray of shape (n_sigmas,)
        Their natural logs.
    sigmas : list of float
        The sigmas.
    """
    logs = np.linspace(np.log(lo), np.log(hi), n_sigmas)
    return logs, [float(np.exp(ls)) for ls in logs]


def sigma_bounds(sq_dist: np.ndarray) -> tuple[float, float]:
    """Return the search bounds for sigma on one node.

    From half the 10th-percentile nearest-neighbour distance up to the node's diameter.
    Below the lower bound most points have no neighbour left (S is almost 0, every split scores
    about 1/|p1|); above the diameter every affinity exceeds exp(-1/2) and D_M flattens. The
    percentile instead of the minimum keeps near-duplicate pairs from stretching the range.

    Parameters
    ----------
    sq_dist : ndarray of shape (m, m)
        Squared distances of the node's points.

    Returns
    -------
    lo, hi : float
        The bounds; ``lo`` falls back to ``1e-3`` times the diameter where half the percentile
        is not in ``(0, diameter)``.
    """
    masked = sq_dist + np.diag(np.full(sq_dist.shape[0], np.inf))
    nn = np.sqrt(masked.min(axis=1))
    diameter = float(np.sqrt(sq_dist.max()))
    return _bounds(nn, diameter)


def _bounds(nn: np.ndarray, diameter: float) -> tuple[float, float]:
    positive = nn[np.isfinite(nn) & (nn > 0)]
    lo = 0.5 * float(np.percentile(positive, 10)) if positive.size else 0.0
    lo = lo if 0.0 < lo < diameter else 1e-3 * diameter
    return lo, diameter


class DenseGeometry:
    """A node given by its squared distances (m, m): the exact path.

    Parameters
    ----------
    sq_dist : ndarray of shape (m, m)
        Squared distances of the node's points.
    coarse : bool, default False
        A sub-node of a graph fit, searched with `coarse_space`.
    """

    def __init__(self, sq_dist: np.ndarray, coarse: bool = False) -> None:
        self.sq_dist = sq_dist
        self.coarse = coarse

    def search_space(self, space):
        """Return the (sigma, alpha) search of this node: ``space`` itself on the exact path.

        Parameters
        ----------
        space : SearchSpace
            The fit's search space.

        Returns
        -------
        SearchSpace
            ``space``, or its `coarse_space` for a sub-node of a graph fit.
        """
        return coarse_space(space) if self.coarse else space

    @property
    def size(self) -> int:
        """Number of points of the node."""
        return self.sq_dist.shape[0]

    def sub(self, idx: np.ndarray) -> DenseGeometry:
        """Return the sub-node of the points ``idx``.

        Parameters
        ----------
        idx : ndarray of int
            Positions of the points within this node.

        Returns
        -------
        DenseGeometry
            Their distances, as coarse as this node.
        """
        return DenseGeometry(self.sq_dist[np.ix_(idx, idx)], self.coarse)

    def basis(self, sigma: float) -> SpectralBasis:
        """Return the exact eigenbasis of S at sigma (nothing is kept: the search caches its own).

        Parameters
        ----------
        sigma : float
            Kernel width.

        Returns
        -------
        SpectralBasis
            The eigenbasis.
        """
        return SpectralBasis.from_sq_distances(self.sq_dist, sigma)

    def sigma_bounds(self) -> tuple[float, float]:
        """Return the search bounds for sigma on this node (`sigma_bounds`).

        Returns
        -------
        lo, hi : float
            The bounds.
        """
        return sigma_bounds(self.sq_dist)

    def has_extent(self) -> bool:
        """Check whether any two of the node's points differ.

        A node of copies of one point, say a robot standing still, has no sigma to search and
        stays a leaf.

        Returns
        -------
        bool
            True when some distance is positive.
        """
        return bool(self.sq_dist.max() > 0)

    def prefetch(self, sigmas) -> None:
        """Do nothing: a dense node's bases are exact ``eigh`` calls its search makes as it goes.

        The search makes them with Brent's refinement of sigma, not only on a grid.

        Parameters
        ----------
        sigmas : sequence of float
            Ignored.
        """

    def portable(self) -> DenseGeometry:
        """Return this node as sent to a worker process for its split: as it is (m x m).

        Returns
        -------
        DenseGeometry
            This node.
        """
        return self

    def block(self, idx: np.ndarray) -> np.ndarray:
        """Return squared distances among the points ``idx`` (for eq. 13's cluster models).

        Parameters
        ----------
        idx : ndarray of int
            Positions of the points within this node.

        Returns
        -------
        ndarray of shape (len(idx), len(idx))
            Their squared distances.
        """
        return self.sq_dist[np.ix_(idx, idx)]

    def outliers(self, sigma: float, alpha: float) -> np.ndarray:
        """Return O_d of eq. 10 on this node at (sigma, alpha).

        Parameters
        ----------
        sigma, alpha : float
            Kernel width and alpha.

        Returns
        -------
        ndarray of shape (m,)
            O_d of each point.
        """
        return outlier_vector(self.basis(sigma).dense_distances(alpha))

    def neighbours(self, k: int) -> np.ndarray:
        """Return the indices of each point's k nearest other points.

        Parameters
        ----------
        k : int
            Neighbours per point; at most ``m - 1`` are given.

        Returns
        -------
        ndarray of int, shape (m, min(k, m - 1))
            Positions of the neighbours, in no particular order.
        """
        k = min(k, self.size - 1)
        masked = self.sq_dist + np.diag(np.full(self.size, np.inf))
        return np.argpartition(masked, k - 1, axis=1)[:, :k]


def knn_edges(X: np.ndarray, n_neighbors: int) -> sp.csr_matrix:
    """Return the symmetrised k-nearest-neighbour graph of the rows of X.

    A CSR matrix of squared distances: an edge where either point is among the other's k
    nearest; duplicates are explicit zeros. ``n_neighbors`` above ``n - 1`` is cut to
    ``n - 1``: the complete graph.

    Brute force in blocks of rows: candidates from a float32 product (half the time of float64
    at image-sized d), ``_KNN_SPARE`` more than needed, then their distances again in float64
    so that the kept distances are exact; memory O(block n + n k).

    Parameters
    ----------
    X : ndarray of shape (n, d)
        The points.
    n_neighbors : int
        k.

    Returns
    -------
    scipy.sparse.csr_matrix of shape (n, n)
        Squared distances of the graph's edges.
    """
    n = X.shape[0]
    k = min(int(n_neighbors), n - 1)
    c = min(k + _KNN_SPARE, n - 1)
    Xc = X - X.mean(axis=0, dtype=np.float64)
    X32 = np.asarray(Xc, dtype=np.float32)
    sq32 = np.einsum("ij,ij->i", X32, X32)
    cand = np.empty((n, c), dtype=np.intp)
    step = max(1, _KNN_ELEMENTS // n)
    for start in range(0, n, step):
        rows = np.arange(start, min(start + step, n))
        D = sq32[rows, None] + sq32[None, :] - 2.0 * (X32[rows] @ X32.T)
        D[np.arange(rows.shape[0]), rows] = np.inf
        cand[rows] = np.argpartition(D, c - 1, axis=1)[:, :c]
    exact = np.empty((n, c))
    step = max(1, _KNN_ELEMENTS // (c * X.shape[1]))
    for start in range(0, n, step):
        rows = slice(start, start + step)
        diff = Xc[rows, None, :] - Xc[cand[rows]]  # (rows, c, d) in float64
        exact[rows] = np.einsum("rcd,rcd->rc", diff, diff)
    best = np.argsort(exact, axis=1, kind="stable")[:, :k]
    ind = np.take_along_axis(cand, best, axis=1)
    dist = np.take_along_axis(exact, best, axis=1)
    rows = np.repeat(np.arange(n), k)
    # +1 keeps zero distances (duplicates) as stored entries through ``maximum``.
    A = sp.csr_matrix((dist.ravel() + 1.0, (rows, ind.ravel())), shape=(n, n))
    A = A.maximum(A.T).tocsr()
    A.data -= 1.0
    np.maximum(A.data, 0.0, out=A.data)
    return A


class GraphGeometry:
    """A node given by the training points and the k-NN graph restricted to the node.

    Parameters
    ----------
    X : ndarray of shape (n, d)
        All training points.
    edges : scipy.sparse.csr_matrix of shape (m, m)
        `knn_edges` restricted to the node's points.
    indices : ndarray of shape (m,)
        Training indices of the node's points.
    rank : int
        Eigenpairs of S kept per sigma (`LowRankBasis.from_edges`).
    dense_below : int
        Sub-nodes of at most this many points use the exact dense path.
    n_neighbors : int
        k of the graph (the neighbours a new point is joined to by eq. 13's graph models).
    n_jobs : int or None
        Processes that compute a node's eigenbases (`prefetch`; joblib's meaning).
    """

    def __init__(
        self,
        X,
        edges,
        indices,
        rank: int,
        dense_below: int,
        n_neighbors: int = 10,
        n_jobs: int | None = None,
    ):
        self.X, self.edges, self.indices = X, edges, indices
        self.rank, self.dense_below, self.n_neighbors = rank, dense_below, n_neighbors
        self.n_jobs = n_jobs
        self._bases: dict[float, LowRankBasis] = {}

    @property
    def size(self) -> int:
        """Number of points of the node."""
        return self.indices.shape[0]

    def sub(self, idx: np.ndarray) -> DenseGeometry | GraphGeometry:
        """Return the sub-node of the points ``idx``: dense up to ``dense_below`` points.

        Parameters
        ----------
        idx : array-like of int
            Positions of the points within this node.

        Returns
        -------
        DenseGeometry or GraphGeometry
            A coarse `DenseGeometry` of their distances, or the graph restricted to them.
        """
        idx = np.asarray(idx)
        if idx.shape[0] <= self.dense_below:
            return DenseGeometry(self.block(idx), coarse=True)
        return self.node(idx)

    def node(self, idx: np.ndarray) -> GraphGeometry:
        """Return the graph restricted to the points ``idx``, at any size.

        Eq. 13's cluster models use the graph kernel their sigma_j was chosen on, also for
        small clusters.

        Parameters
        ----------
        idx : array-like of int
            Positions of the points within this node.

        Returns
        -------
        GraphGeometry
            The sub-graph; this node itself when ``idx`` is all of it in order.
        """
        idx = np.asarray(idx)
        if idx.shape[0] == self.size and np.array_equal(idx, np.arange(self.size)):
            return self  # the root: its bases serve the split, the combination and eq. 10
        edges = self.edges[idx][:, idx].tocsr()
        return GraphGeometry(
            self.X,
            edges,
            self.indices[idx],
            self.rank,
            self.dense_below,
            self.n_neighbors,
            self.n_jobs,
        )

    def basis(self, sigma: float) -> LowRankBasis:
        """Return the low-rank basis of S at sigma, kept for the next call.

        Keeping costs O(n_sigmas m r): the search asks only for its grid's sigmas. The root's
        are asked for by its split, the combination (on the same grid) and eq. 10.

        Parameters
        ----------
        sigma : float
            Kernel width.

        Returns
        -------
        LowRankBasis
            The basis.
        """
        if sigma not in self._bases:
            self._bases[sigma] = LowRankBasis.from_edges(self.edges, sigma, self.rank)
        return self._bases[sigma]

    def prefetch(self, sigmas) -> None:
        """Compute the bases at ``sigmas`` not kept yet in ``n_jobs`` processes at once.

        The split search needs its whole grid (`coarse_space`), and each sigma is one
        independent eigensolve; together they are half to two thirds of a graph fit's time
        (ARPACK holds the GIL, so threads do not help). Each process runs BLAS on one thread,
        as ``fit`` does, so the bases, and the fit, do not depend on ``n_jobs``. With one job
        this does nothing: `basis` computes each sigma when it is asked for.

        Parameters
        ----------
        sigmas : sequence of float
            The sigmas whose bases are wanted.
        """
        missing = [s for s in sigmas if s not in self._bases]
        if len(missing) < 2 or effective_n_jobs(self.n_jobs) < 2:
            return
        found = Parallel(n_jobs=self.n_jobs)(
            delayed(on_one_blas_thread)(LowRankBasis.from_edges, self.edges, s, self.rank)
            for s in missing
        )
        self._bases.update(zip(missing, found, strict=True))

    def portable(self) -> GraphGeometry:
        """Return this node as sent to a worker process for its split, which needs only the graph.

        Without the training points (n x d) and on one job. Where no edge has a positive
        length, sigma's bounds come from the points' distances; then their rows go along.

        Returns
        -------
        GraphGeometry
            The light copy.
        """
        E = self.edges
        if E.data.size and E.data.max() > 0:
            X, indices = None, self.indices
        else:
            X, indices = self.X[self.indices], np.arange(self.size)
        return GraphGeometry(X, E, indices, self.rank, self.dense_below, self.n_neighbors, 1)

    def has_extent(self) -> bool:
        """Check whether any two of the node's points differ, as `DenseGeometry.has_extent`.

        A positive edge decides it without the points.

        Returns
        -------
        bool
            True when the points are not all one.
        """
        E = self.edges
        if E.data.size and E.data.max() > 0:
            return True
        return bool(self.X is not None and np.ptp(self.X[self.indices], axis=0).max() > 0)

    def search_space(self, space):
        """Return the (sigma, alpha) search of a graph node: `coarse_space`.

        Parameters
        ----------
        space : SearchSpace
            The fit's search space.

        Returns
        -------
        SearchSpace
            Its `coarse_space`.
        """
        return coarse_space(space)

    def sigma_bounds(self) -> tuple[float, float]:
        """Return the search bounds for sigma, as `sigma_bounds`, on the graph's edges.

        The nearest neighbour and the diameter are taken on the graph's edges: beyond the
        longest edge the affinities only approach 1 (a kernel wider than the graph has no
        meaning), so that is the upper bound.

        Returns
        -------
        lo, hi : float
            The bounds.
        """
        nn = np.full(self.size, np.inf)
        lengths = np.sqrt(self.edges.data)
        has = np.diff(self.edges.indptr) > 0
        nn[has] = np.minimum.reduceat(lengths, self.edges.indptr[:-1][has])
        if not lengths.size or not lengths.max() > 0:
            return _bounds(nn, float(np.sqrt(self.block(np.arange(self.size)).max())))
        return _bounds(nn, float(lengths.max()))

    def block(self, idx: np.ndarray) -> np.ndarray:
        """Return squared distances among the points ``idx``, computed from the points.

        Parameters
        ----------
        idx : ndarray of int
            Positions of the points within this node.

        Returns
        -------
        ndarray of shape (len(idx), len(idx))
            Their squared distances.
        """
        return squared_distances(self.X[self.indices[idx]])

    def outliers(self, sigma: float, alpha: float) -> np.ndarray:
        """Return O_d of eq. 10 on this node at (sigma, alpha), from the low-rank basis.

        Parameters
        ----------
        sigma, alpha : float
            Kernel width and alpha.

        Returns
        -------
        ndarray of shape (m,)
            O_d of each point.
        """
        basis = self.basis(sigma)
        return unit_outliers(basis, basis.gains(np.array([alpha])))[2][:, 0]

    def neighbours(self, k: int) -> np.ndarray:
        """Return up to k graph neighbours per point, nearest first.

        A point's own index pads a short row.

        Parameters
        ----------
        k : int
            Neighbours per point.

        Returns
        -------
        ndarray of int, shape (m, k)
            Positions of the neighbours.
        """
        out = np.repeat(np.arange(self.size)[:, None], k, axis=1)
        E = self.edges
        for i in range(self.size):
            start, stop = E.indptr[i], E.indptr[i + 1]
            nearest = E.indices[start:stop][np.argsort(E.data[start:stop], kind="stable")[:k]]
            out[i, : nearest.shape[0]] = nearest
        return out


def training_geometry(
    X: np.ndarray, kernel: str, n_neighbors: int, n_components: int, n_jobs: int | None = None
) -> DenseGeometry | GraphGeometry:
    """Return the geometry of all training points for ``ManifoldClustering(kernel=...)``.

    Dense: squared distances once, in float64 after centring (a float32 Gram matrix loses
    near-duplicate images entirely); every node and every sigma reuses blocks of it. Sparse:
    the k-NN graph, and nodes of at most ``4 n_components`` points dense; ``n_jobs``
    processes compute each graph node's eigenbases (`GraphGeometry.prefetch`).

    Parameters
    ----------
    X : ndarray of shape (n, d)
        Training points.
    kernel : {"auto", "dense", "sparse"}
        The path; "auto" is sparse above ``AUTO_SPARSE_ABOVE`` points.
    n_neighbors : int
        k of the graph.
    n_components : int
        Eigenpairs kept per sigma on the graph path.
    n_jobs : int, optional
        Processes that compute a graph node's eigenbases.

    Returns
    -------
    DenseGeometry or GraphGeometry
        The geometry of the root node.
    """
    n = X.shape[0]
    span = check_span(X)  # refuses a span float64 distances cannot hold
    if kernel == "sparse" or (kernel == "auto" and n > AUTO_SPARSE_ABOVE):
        if not span > 0:
            raise ValueError("X: all samples are identical; there is nothing to cluster")
        rank = int(n_components)
        k = min(int(n_neighbors), n - 1)
        return GraphGeometry(X, knn_edges(X, k), np.arange(n), rank, 4 * rank, k, n_jobs)
    D2 = squared_distances(X)
    if not D2.max() > 0:
        raise ValueError("X: all samples are identical; there is nothing to cluster")
    return DenseGeometry(D2)


def as_geometry(x) -> DenseGeometry | GraphGeometry:
    """Return a geometry as is; a square array of squared distances as a `DenseGeometry`.

    Parameters
    ----------
    x : DenseGeometry, GraphGeometry or ndarray of shape (m, m)
        A geometry, or squared distances.

    Returns
    -------
    DenseGeometry or GraphGeometry
        The geometry.
    """
    return x if isinstance(x, DenseGeometry | GraphGeometry) else DenseGeometry(np.asarray(x))
