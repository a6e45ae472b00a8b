"""eq. 13 (Section II-F/G) for every cluster at once, each query projected once for all of them.

`Projection` keeps what the distances of all K clusters need of a query in one matrix:

* ``mu``, the training mean (the size-weighted mean of the cluster means), float64;
* ``matrix`` (R, d) in the storage dtype: every cluster's rows V_j (the basis B_j of a
  [`ClusterModel`][mapping.manifold.cluster_model.ClusterModel], the centred points P_j of a
  [`GraphClusterModel`][mapping.manifold.graph_cluster_model.GraphClusterModel]; R = sum of their
  counts);
* ``shifts`` (K, d), float64: the shift directions ``delta_j = mean_j - mu``;
* ``offsets``: ``V_j delta_j`` (float64, from the stored V_j), and ``|delta_j|^2``.

With ``y = x - mu`` and ``x - mean_j = y - delta_j``, what each cluster's own
``sq_distances`` computes follows from the products ``p = matrix y`` and ``s = shifts y``:

    V_j (x - mean_j) = p[V_j rows] - V_j delta_j,
    |x - mean_j|^2 = |y|^2 - 2 s_j + |delta_j|^2,

and ``|x - x_i|^2 = |x - mean_j|^2 + |x_i - mean_j|^2 - 2 c_j . c_i`` (c_j = B_j (x - mean_j))
or ``- 2 (x - mean_j) . p_i`` as before; eq. 13 then reads its affinities from these. So a
view costs one norm, one GEMV over the K shifts and mu in float64 (``|y|^2`` and ``s`` from
``x . x``, ``x . mu`` and ``x . delta_j``), one subtraction rounded straight into the
storage dtype and one GEMV over the stacked matrix (memory-bound: they read R rows of d in
the storage dtype and K + 1 in float64 once), instead of K centrings, casts and GEMVs; no K
x d or n x d temporary is formed, nor a float64 copy of the query. The maths is exact. The
round-off differs from the per-cluster path only in float32 storage, where the query is
rounded after centring on mu instead of on mean_j; the coordinates' error stays of the order
of the per-cluster path's (the rounding error of y is projected on unit rows; measured the
same to a factor of 2). ``s`` is float64 on purpose: |x - mean_j|^2 is a small difference of
the large |y|^2 and |delta_j|^2 for a query near cluster j, and a float32 ``y . delta_j``
made it 1 % wrong on the tests' data (3000-d curves 20x their spread apart), ~1e-3 of F.
tests/mapping/manifold/test_stacked_signal.py bounds the difference.

Two things cut what a view reads further (the target: <= 2 ms at 320x240x3):

* **Unreachable clusters are skipped.** ``q`` comes first (K rows of d); a cluster whose
  nearest possible point, ``(sqrt(q_j) - radius_j)^2``, lies beyond exp's underflow at its
  sigma (`Stack.reachable`) has every affinity exactly 0 and F^j exactly 0, so its
  rows of ``matrix`` are not read. Exact: the same F, the same labels. On the benchmark's
  held-out views a view reaches 2-3 of the 8 clusters. ``predict``'s fallback (every F 0)
  needs every cluster's nearest point, and recomputes those rows unpruned.
* **Two BLAS threads where a core is free** (`projection_threads`): two cores stream
  twice the bytes of one, but OpenBLAS's threads spin-wait for a descheduled partner, so a
  busy machine (`mapping.validation.busy`) keeps one.

`Stack` (``predict`` of a dense fit) pads every ``ClusterModel``'s arrays to one size,
so that the K eq. 13 solves of a batch are a few batched numpy calls; ``model_scores`` of a
graph fit uses the `Projection` of its models' points.

Memory: when the projection is built the models' rows become row blocks (views, the same
values) of ``matrix``, so it adds only the K shifts (K d float64), mu (d float64) and R
float64 offsets to what the models hold; the stack adds the padded coordinates
(K r n) and inverses (K n^2) of the solves. Both are derived, never saved
(`mapping.persistence` saves the models' fields) nor pickled or deep-copied
(`DerivedCache`); a loaded or copied model builds them again on its first ``predict``.
"""

from __future__ import annotations

from contextlib import nullcontext

import numpy as np

from common.blas import busy, single_threaded_blas
from mapping.manifold.signal_solvers import dense_signal, sparse_signal

# Query elements centred at once (~32 MB of float64).
CENTRE_ELEMENTS = 4_000_000
# Blocks of at most this many rows are projected on one BLAS thread on a busy machine: a GEMV
# (or a product of a few rows) is memory-bound, and there a second OpenBLAS thread only spins
# (a 40 x 230400 float32 GEMV: ~1.7 ms on one thread, ~12 ms on two at load 4-5). Below
# _SMALL_MATRIX elements (d=2000: a cluster's 66 x 2000 basis) the switch costs more than it
# saves (~20 us of a 0.2 ms signal) and the default threads stay.
_FEW_ROWS = 8
_SMALL_MATRIX = 1 << 20
# A cluster whose nearest possible point lies further than this many (2 sigma_j^2) from a
# query has affinities exp(-UNDERFLOW) = 0 in float64 (exp underflows below -745).
UNDERFLOW = 800.0
# Columns of a float32 basis widened to float64 at once for ``B_j delta_j``.
_OFFSET_COLUMNS = 65_536


class Projection:
    """The models' rows stacked, and the K shift directions, to project a query once for all.

    The rows are the bases B_j, or a graph fit's centred points; see the module docstring.
    From construction on each model's array is a row block (a view) of ``matrix``. Memory
    beyond the models': ``shifts`` (K d float64), ``mu`` (d float64) and ``offsets``
    (R float64).

    Parameters
    ----------
    models : tuple of ClusterModel or GraphClusterModel
        One model per cluster.
    field : str
        Name of the models' (r_j, d) array.
    """

    def __init__(self, models: tuple, field: str) -> None:
        self.models, self.field = models, field
        K = len(models)
        blocks = [getattr(m, field) for m in models]
        sizes = np.array([m.indices.shape[0] for m in models], dtype=np.float64)
        self.mu = np.zeros(models[0].mean.shape[0])
        for weight, m in zip(sizes / sizes.sum(), models, strict=True):
            self.mu += weight * m.mean
        self.starts = np.concatenate([[0], np.cumsum([b.shape[0] for b in blocks])])
        self.starts = self.starts.astype(np.intp)
        R = int(self.starts[-1])
        self.owner = np.repeat(np.arange(K), np.diff(self.starts))  # the model of each row
        self.matrix = np.empty((R, self.mu.shape[0]), dtype=blocks[0].dtype)
        # the K shifts and mu as one (K + 1, d) matrix: one float64 GEMV gives x . delta_j
        # and x . mu, so the query is never centred in float64 (only into the float32 cast)
        self.anchors = np.empty((K + 1, self.mu.shape[0]))
        self.anchors[K] = self.mu
        self.mu = self.anchors[K]
        self.shifts = self.anchors[:K]
        self.offsets = np.empty(R)
        self.shift_sq = np.empty(K)
        for j, (m, rows) in enumerate(zip(models, blocks, strict=True)):
            a, b = self.starts[j], self.starts[j + 1]
            delta = self.shifts[j]
            np.subtract(m.mean, self.mu, out=delta)
            self.matrix[a:b] = rows
            self.shift_sq[j] = delta @ delta
            self.offsets[a:b] = _widened_product(rows, delta)
            # the model reads the same values from here on: no second copy of its rows
            object.__setattr__(m, field, self.matrix[a:b])
        self.mu_shift = self.shifts @ self.mu  # mu . delta_j
        self.mu_sq = float(self.mu @ self.mu)

    @classmethod
    def of(cls, models: list, field: str) -> Projection:
        """Return the projection of these models, built once and kept by the first of them.

        Parameters
        ----------
        models : list of ClusterModel or GraphClusterModel
            One model per cluster.
        field : str
            Name of the models' (r_j, d) array.

        Returns
        -------
        Projection
            The cached projection.
        """
        return _cached(cls, models, field)

    def __call__(self, X: np.ndarray, needed=None) -> tuple[np.ndarray, np.ndarray]:
        """Return ``(p, q)`` for the rows of X, both float64.

        ``p`` (k, R) is the rows of every model times ``x - mean_j`` (model j's columns
        ``starts[j]:starts[j + 1]``), ``q`` (k, K) is ``|x - mean_j|^2``.
        Each block of rows is centred on ``mu``, cast and projected once for all clusters.
        ``needed``, if given, maps a block's ``q`` to a (rows, K) bool mask of the models whose
        coordinates are wanted; the columns of a model no row of the block needs are not
        computed (left NaN): ``q`` costs K rows of d, the coordinates R.
        """
        k, d = X.shape
        p = np.empty((k, self.matrix.shape[0]))
        q = np.empty((k, self.shifts.shape[0]))
        step = max(1, CENTRE_ELEMENTS // max(d, 1))
        for start in range(0, k, step):
            rows = slice(start, start + step)
            self._project(X[rows], p[rows], q[rows], needed)
        p -= self.offsets  # V_j (x - mean_j) = V_j (x - mu) - V_j delta_j
        return p, q

    def _project(self, X: np.ndarray, p: np.ndarray, q: np.ndarray, needed) -> None:
        """Project one block of rows into ``p`` and ``q`` (see ``__call__``).

        In float64, from ``x . x`` and ``x . [delta_j, mu]``: ``y = x - mu`` has
        ``|y|^2 = |x|^2 - 2 x . mu + |mu|^2`` and ``y . delta_j = x . delta_j - mu . delta_j``
        (float64 keeps these differences to ~1e-16 of |x|^2, far below the float32
        projection's round-off); y itself is only formed rounded to the storage dtype.
        """
        k = X.shape[0]
        K = self.shifts.shape[0]
        norms = np.einsum("ij,ij->i", X, X, dtype=np.float64)  # float32 queries too
        with projection_threads(k, self.matrix):
            g = X @ self.anchors.T
            y_sq = norms - 2.0 * g[:, K] + self.mu_sq
            along = g[:, :K] - self.mu_shift
            # |x - mean_j|^2 = |x - mu|^2 - 2 (x - mu) . delta_j + |delta_j|^2
            q[:] = y_sq[:, None] - 2.0 * along + self.shift_sq
            wanted = None if needed is None else needed(q).any(axis=0)
            # centred in float64 element by element, rounded once (no float64 copy of X)
            Xc = np.subtract(
                X, self.mu, out=np.empty(X.shape, self.matrix.dtype), casting="same_kind"
            )
            for a, b in self._runs(wanted):
                p[:, a:b] = Xc @ self.matrix[a:b].T
        if wanted is not None:
            p[:, ~wanted[self.owner]] = np.nan

    def _runs(self, wanted: np.ndarray | None) -> list[tuple[int, int]]:
        """Return row ranges of ``matrix`` of the wanted models, consecutive models in one range."""
        if wanted is None:
            return [(0, int(self.matrix.shape[0]))]
        starts = self.starts.tolist()  # K + 1 Python ints: a plain loop beats numpy's calls here
        runs: list[tuple[int, int]] = []
        for j, on in enumerate(wanted.tolist()):
            if on and runs and runs[-1][1] == starts[j]:
                runs[-1] = (runs[-1][0], starts[j + 1])
            elif on:
                runs.append((starts[j], starts[j + 1]))
        return runs


class Stack:
    """Every cluster's arrays padded to the largest cluster, and the stacked projection.

    Padding: zero basis coordinates and an infinite squared norm (a padded point is at
    infinite distance, affinity exactly 0), H = 0 and degree 1 (never in a support).

    Parameters
    ----------
    models : tuple of ClusterModel
        One model per cluster.
    """

    def __init__(self, models: tuple) -> None:
        self.models = models
        K = len(models)
        sizes = [m.indices.shape[0] for m in models]
        n, r = max(sizes), max(m.basis.shape[0] for m in models)
        self.sizes = np.array(sizes)
        self.ranks = [m.basis.shape[0] for m in models]
        self.coords_t = np.zeros((K, r, n))
        self.sq_norms = np.full((K, n), np.inf)
        self.inverse = np.zeros((K, n, n))
        self.degrees = np.ones((K, n))
        for j, m in enumerate(models):
            size, rank = sizes[j], self.ranks[j]
            self.coords_t[j, :rank, :size] = m.coords.T
            self.sq_norms[j, :size] = m.sq_norms
            if m.inverse is not None:  # else H = 0, d = 1: harmless until dense_signal's turn
                self.inverse[j, :size, :size] = m.inverse
                self.degrees[j, :size] = m.degrees
        self.dense = [j for j, m in enumerate(models) if m.inverse is None]
        self.centres = np.array([m.centre for m in models], dtype=np.intp)
        self.alphas = np.array([m.alpha for m in models])
        self.scales = np.array([m.scale for m in models])
        self.gain = np.array([-0.5 / (m.sigma * m.sigma) for m in models])
        # the largest |x_i - mean_j| (the part outside the basis included): the bound of
        # ``reachable``
        radius = np.array([np.sqrt(m.sq_norms.max(initial=0.0)) for m in models])
        # ``reachable``'s bound as one comparison: gap^2 / (2 sigma^2) < UNDERFLOW, with
        # gap = max(sqrt(q) - radius, 0), holds exactly where sqrt(q) < radius + reach
        self.reach_sq = (radius + np.sqrt(UNDERFLOW / -self.gain)) ** 2
        self.projection = Projection(models, "basis")
        # c of cluster j is the projection's columns starts[j]:starts[j + 1]; the padding
        # gathers column R, a zero appended to each projection
        starts = self.projection.starts
        self.gather = np.full((K, r), starts[-1], dtype=np.intp)
        for j in range(K):
            self.gather[j, : self.ranks[j]] = np.arange(starts[j], starts[j + 1])

    @classmethod
    def of(cls, models: list) -> Stack:
        """Return the stack of these models, built once and kept by the first of them.

        Parameters
        ----------
        models : list of ClusterModel
            One model per cluster.

        Returns
        -------
        Stack
            The cached stack.
        """
        return _cached(cls, models)

    def reachable(self, q: np.ndarray) -> np.ndarray:
        """Check whether a query with ``q = |x - mean_j|^2`` can reach a point of cluster j.

        Reaching means an affinity above 0.
        The distance as computed, ``q + |x_i - mean_j|^2 - 2 c . c_i`` (c = B_j (x - mean_j),
        ``|c|^2 <= q``, ``|c_i|^2 <= |x_i - mean_j|^2 <= radius_j^2``), is at least
        ``(sqrt(q) - radius_j)^2`` (Cauchy-Schwarz), so where that bound times
        ``1 / (2 sigma_j^2)`` exceeds ``UNDERFLOW`` every affinity ``exp(-d^2 / 2 sigma_j^2)``
        is exactly 0 in float64 (below exp(-745)), with margin for round-off, and the
        cluster's F^j is exactly 0 without its coordinates.

        Parameters
        ----------
        q : ndarray of shape (k, K)
            ``|x - mean_j|^2`` of each query and cluster.

        Returns
        -------
        ndarray of bool, shape (k, K)
            True where the cluster may be reached.
        """
        return q < self.reach_sq

    def sq_distances(self, X: np.ndarray, prune: bool = False) -> np.ndarray:
        """Return ``ClusterModel.sq_distances`` of every cluster, padding at infinity.

        The query is projected once for all clusters (`Projection`); the same
        distances as each cluster's own up to the round-off of the projection. With
        ``prune``, a cluster the query cannot reach (`reachable`) is not projected on
        and its distances are infinite (every affinity 0, as computed they underflow to 0).

        Parameters
        ----------
        X : ndarray of shape (k, d)
            Queries.
        prune : bool, default False
            Skip the clusters a query cannot reach.

        Returns
        -------
        ndarray of shape (K, k, n)
            Squared distances to each cluster's points, n the largest cluster's size.
        """
        p, q = self.projection(X, self.reachable if prune else None)
        p = np.concatenate([p, np.zeros((p.shape[0], 1))], axis=1)
        c = p[:, self.gather].transpose(1, 0, 2)  # (K, k, r)
        d2 = np.matmul(c, self.coords_t)
        d2 *= -2.0
        d2 += q.T[:, :, None]
        d2 += self.sq_norms[:, None, :]
        if prune:
            d2[~self.reachable(q).T] = np.inf
        return np.maximum(d2, 0.0, out=d2)

    def scores(self, X: np.ndarray, normalize: bool) -> tuple[np.ndarray, np.ndarray]:
        """Return F^j(k) of eq. 13 toward each centre and the scaled nearest distances.

        F (k, K) is divided by ``scale`` if ``normalize``; ``min_i |x - x_i|^2 / (2 sigma_j^2)``
        (k, K) is exact for the rows where every F is 0 (other rows: infinite for the clusters
        they cannot reach, which were not projected on: `reachable`; a query near one or two
        of the clusters reads their bases only, a third of the bytes on the benchmark's
        images).

        Parameters
        ----------
        X : ndarray of shape (k, d)
            Queries.
        normalize : bool
            Divide F by each model's ``scale``.

        Returns
        -------
        f : ndarray of shape (k, K)
            F^j(k) of each query and cluster.
        nearest : ndarray of shape (k, K)
            The scaled distance to each cluster's nearest point.
        """
        f, nearest = self._scores(X, normalize, prune=True)
        lost = np.flatnonzero(~(f.max(axis=1) > 0))
        if len(lost):  # the fallback needs every cluster's nearest point
            nearest[lost] = self._scores(X[lost], normalize, prune=False)[1]
        return f, nearest

    def _scores(self, X: np.ndarray, normalize: bool, prune: bool):
        d2 = self.sq_distances(X, prune)
        K, k = d2.shape[:2]
        w = np.exp(d2 * self.gain[:, None, None])
        entry = np.repeat(np.arange(K), k)
        # each solve limits the BLAS threads itself where OpenBLAS would use more than one
        # (eq13._THREADED_SOLVE): a second thread only spins on these small systems
        f = sparse_signal(
            self.inverse,
            self.degrees,
            w.reshape(K * k, -1),
            entry,
            self.centres[entry],
            self.alphas[entry],
        ).reshape(K, k)
        for j in self.dense:
            m = self.models[j]
            w_j = w[j, :, : self.sizes[j]]
            f[j] = dense_signal(m.weights, m.degrees, m.alpha, w_j, m.centre)
        if normalize:
            f /= self.scales[:, None]
        return f.T, (d2.min(axis=2) * -self.gain[:, None]).T


class DerivedCache:
    """Base of the frozen per-cluster records, with their cache of derived stacks.

    Their ``_stacks`` dict (set on construction) keeps the `Stack` / `Projection` built from
    them on the first ``predict``. Pickles and deep copies leave it out (a copy builds its
    own), as saved files do.
    """

    def __getstate__(self) -> dict:
        """Return the state to pickle, without ``_stacks``."""
        state = dict(self.__dict__)
        state.pop("_stacks", None)
        return state

    def __setstate__(self, state: dict) -> None:
        """Restore a pickled state with an empty ``_stacks``."""
        self.__dict__.update(state)
        self.__dict__["_stacks"] = {}


def projection_threads(rows: int, matrix: np.ndarray):
    """Return the BLAS threads' context for projecting ``rows`` queries on ``matrix``.

    For a few rows and a large matrix (a memory-bound GEMV; ``_FEW_ROWS``) one thread on a
    `busy` machine, where a second would spin, and the default where a core is free (idle, 2
    cores: ``predict`` of one 320x240x3 view 3.6 -> 2.6 ms); the default otherwise (a product
    of many rows is compute-bound, as in ``fit``; a small one is not worth the switch).

    Parameters
    ----------
    rows : int
        Queries projected at once.
    matrix : ndarray
        The matrix they are projected on.

    Returns
    -------
    contextlib.AbstractContextManager
        ``single_threaded_blas()`` or a null context.
    """
    if rows <= _FEW_ROWS and matrix.size >= _SMALL_MATRIX and busy():
        return single_threaded_blas()
    return nullcontext()


def _cached(cls, models: list, *args):
    """Return ``cls(tuple(models), *args)``, built once and kept by the first model."""
    cache = models[0]._stacks
    key = (cls.__name__, *args, *map(id, models))
    hit = cache.get(key)
    # the object holds the models, so while cached their ids cannot be reused
    if hit is None or any(a is not b for a, b in zip(hit.models, models, strict=True)):
        hit = cache[key] = cls(tuple(models), *args)
    return hit


def _widened_product(basis: np.ndarray, vector: np.ndarray) -> np.ndarray:
    """Return ``basis @ vector`` in float64 for a float32 or float64 basis.

    A block of columns at a time: no float64 copy of a whole image-sized basis.
    """
    out = np.zeros(basis.shape[0])
    for start in range(0, basis.shape[1], _OFFSET_COLUMNS):
        cols = slice(start, start + _OFFSET_COLUMNS)
        out += np.asarray(basis[:, cols], dtype=np.float64) @ vector[cols]
    return out
