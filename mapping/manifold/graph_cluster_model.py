"""eq. 13 (Grudic & Mulligan, Section II-F/G) for a large cluster of a k-NN graph fit.

The scalable path's counterpart of [`ClusterModel`][mapping.manifold.cluster_model.ClusterModel]:
nothing in it is m x m. The cluster's kernel is the one its (sigma_j, alpha_j) were chosen on: the
k-NN graph restricted to the cluster and the low-rank inverse of `LowRankBasis`,

    H = (I - alpha S)^-1 ~ Q diag(g - e_col) Q^T + diag(e),  g = 1 / (1 - alpha lam),

with e the gain of each component's mean left-out eigenvalue. A query x joins the graph through
its ``n_neighbors`` nearest cluster points (w is 0 elsewhere, as on the training graph), and
eq. 13 is the same Woodbury form as ``mapping.manifold.signal_solvers.sparse_signal`` (see
``mapping.manifold.cluster_model`` for the derivation), with ``H_SS`` and ``H_tS`` assembled from
the factors: O(k^2 r) per query. Training points of degree 0 in the cluster's graph (all
their neighbours in other clusters, or underflow at sigma_j) are left out of a query's
support, where the Woodbury form would divide by their degree.

Memory per cluster: the centred points (m d, as the dense model's basis and coordinates), the
eigenvectors (m r) and the degrees; O(n d + n r) over the clusters, not O(n^2 / K).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from mapping.distances import TINY
from mapping.manifold.cluster_model import ClusterModel, check_scalars
from mapping.manifold.geometry import GraphGeometry
from mapping.manifold.kernel import unit_outliers
from mapping.manifold.lowrank_kernel import LowRankBasis
from mapping.manifold.stacked_signal import DerivedCache, Projection, projection_threads
from mapping.validation import check_layout, check_number

# Query rows centred at once (~32 MB of float64).
_ROW_ELEMENTS = 4_000_000


@dataclass(frozen=True)
class GraphClusterModel(DerivedCache):
    """What eq. 13 needs of one cluster of a k-NN graph fit, in low-rank form.

    Attributes
    ----------
    indices : ndarray of int, shape (m,)
        Training indices of the cluster's points.
    sigma, alpha : float
        sigma_j and the alpha of eq. 13.
    centre : int
        Position of the centre x_lj within ``indices``.
    n_neighbors : int
        Cluster points a query is joined to (the fit's k).
    mean : ndarray of shape (d,), float64
        Mean of the cluster's points.
    points : ndarray of shape (m, d)
        The centred points, in the storage dtype.
    sq_norms : ndarray of shape (m,), float64
        Their squared norms.
    vectors, values, col_rest, point_rest : ndarray
        Q (m, r), lam (r,), and the mean left-out eigenvalue of each column's and each
        point's component (`LowRankBasis`).
    degrees : ndarray of shape (m,)
        Degrees of the cluster's graph at sigma_j.
    scale : float
        ``|beta H e_centre|``, eq. 4's column norm, the divisor of ``predict``'s F.

    Once ``predict`` has projected a query, ``points`` is a row block (a view, the same values)
    of the `Projection` of all the clusters' points.

    Parameters
    ----------
    indices, sigma, alpha, centre, n_neighbors, mean, points, sq_norms
        The attributes above.
    vectors, values, col_rest, point_rest, degrees, scale
        The attributes above. All are as
        [`build`][mapping.manifold.graph_cluster_model.GraphClusterModel.build] computes them from a
        cluster's graph and its low-rank basis (``ManifoldClustering.fit`` with ``kernel="sparse"``
        builds them).

    Examples
    --------
    >>> import numpy as np
    >>> from mapping.manifold import GraphClusterModel
    >>> from mapping.manifold.geometry import GraphGeometry, knn_edges
    >>> from mapping.manifold.lowrank_kernel import LowRankBasis
    >>> X = np.c_[np.linspace(0.0, 1.0, 40), np.zeros(40)]
    >>> geometry = GraphGeometry(X, knn_edges(X, 10), np.arange(40), rank=20, dense_below=0,
    ...                          n_neighbors=10)
    >>> basis = LowRankBasis.from_edges(geometry.edges, 0.1, rank=20)
    >>> model = GraphClusterModel.build(X, geometry, basis, 0.1, 0.99, 20, np.dtype(np.float64))
    >>> F = model.signal(model.sq_distances(X[[19, 39]]), target=20)
    >>> bool(F[0] > F[1])  # nearer the target view along the manifold, larger F
    True

    See Also
    --------
    mapping.manifold.ClusterModel : The same for a cluster of a dense fit.
    mapping.manifold.ManifoldClustering : Its ``kernel="sparse"`` fit builds these models.
    """

    indices: np.ndarray
    sigma: float
    alpha: float
    centre: int
    n_neighbors: int
    mean: np.ndarray
    points: np.ndarray
    sq_norms: np.ndarray
    vectors: np.ndarray
    values: np.ndarray
    col_rest: np.ndarray
    point_rest: np.ndarray
    degrees: np.ndarray
    scale: float

    def __post_init__(self) -> None:
        """Start the cache of derived projections empty."""
        # not a field: the derived projection of ``model_scores``, never saved
        object.__setattr__(self, "_stacks", {})

    def validate(self) -> dict[str, int]:
        """Check the fields' shapes, values and agreement (a model read from a file).

        As [`ClusterModel.validate`][mapping.manifold.cluster_model.ClusterModel.validate].

        Returns
        -------
        dict of str to int
            The sizes ``m`` (points), ``d`` (features) and ``r`` (eigenpairs).

        Raises
        ------
        ValueError
            If a field is malformed.
        """
        sizes = check_layout(
            self,
            {
                "indices": ("m",),
                "mean": ("d",),
                "points": ("m", "d"),
                "sq_norms": ("m",),
                "vectors": ("m", "r"),
                "values": ("r",),
                "col_rest": ("r",),
                "point_rest": ("m",),
                "degrees": ("m",),
            },
        )
        check_scalars(self, sizes["m"])
        check_number(self.n_neighbors, "n_neighbors", 1, 2**31 - 1, integer=True)
        spectra = (self.values, self.col_rest, self.point_rest)
        if any(np.abs(v).max(initial=0.0) > 1.0 for v in spectra):
            raise ValueError("values, col_rest and point_rest must lie in [-1, 1]")
        if self.degrees.min(initial=0.0) < 0:
            raise ValueError("degrees must be >= 0")
        return sizes

    @classmethod
    def build(cls, X, geometry: GraphGeometry, basis: LowRankBasis, sigma, alpha, centre, dtype):
        """Build the model of the cluster ``geometry`` (a graph node) from its basis at sigma_j.

        Parameters
        ----------
        X : ndarray of shape (n, d)
            Training data.
        geometry : GraphGeometry
            The cluster's node of the k-NN graph.
        basis : LowRankBasis
            The low-rank basis of the cluster's graph at ``sigma``.
        sigma : float
            sigma_j.
        alpha : float
            alpha of eq. 13.
        centre : int
            Position of the centre within the cluster.
        dtype : numpy.dtype
            Storage dtype of the centred points.

        Returns
        -------
        GraphClusterModel
            The model.
        """
        points = X[geometry.indices]
        mean = points.mean(axis=0, dtype=np.float64)
        centred = np.asarray(points - mean, dtype=np.float64)
        W = geometry.edges.copy()
        W.data = np.exp(W.data * (-0.5 / (sigma * sigma)))
        g = basis.gains(np.array([alpha]))
        return cls(
            indices=geometry.indices,
            sigma=float(sigma),
            alpha=float(alpha),
            centre=int(centre),
            n_neighbors=int(geometry.n_neighbors),
            mean=mean,
            points=np.ascontiguousarray(centred, dtype=dtype),
            sq_norms=np.einsum("ij,ij->i", centred, centred),
            vectors=basis.vectors,
            values=basis.values,
            col_rest=basis.rest_means[basis.col_comp],
            point_rest=basis.rest_means[basis.point_comp],
            degrees=np.asarray(W.sum(axis=1)).ravel(),
            scale=float((1.0 - alpha) * basis.column_norms(g)[centre, 0]),
        )

    def sq_distances(self, X: np.ndarray) -> np.ndarray:
        """Return squared distances of rows of X to the cluster's points, clipped at 0.

        Parameters
        ----------
        X : ndarray of shape (k, d)
            Queries.

        Returns
        -------
        ndarray of shape (k, m)
            Squared distances.
        """
        k, d = X.shape
        out = np.empty((k, self.indices.shape[0]))
        step = max(1, _ROW_ELEMENTS // max(d, 1))
        for start in range(0, k, step):
            Xc = X[start : start + step] - self.mean
            q = np.einsum("ij,ij->i", Xc, Xc)
            with projection_threads(Xc.shape[0], self.points):
                cross = np.asarray(Xc, dtype=self.points.dtype) @ self.points.T
            out[start : start + step] = q[:, None] + self.sq_norms[None, :] - 2.0 * cross
        return np.maximum(out, 0.0, out=out)

    def signal(
        self, sq_dist: np.ndarray, target: int, reach: np.ndarray | None = None
    ) -> np.ndarray:
        """Return F^j(k) of eq. 13 for each row of ``sq_dist`` toward local index ``target``.

        Uses ``beta = 1 - alpha``; 0 where x reaches no cluster point at sigma_j. x is joined
        to its ``n_neighbors`` nearest cluster points; ``reach``, if given, further keeps only
        those within that squared distance (``predict``: x's k nearest training points of all
        clusters, the edges the fit's graph would give it).

        Parameters
        ----------
        sq_dist : ndarray of shape (k, m)
            Squared distances of the queries to the cluster's points.
        target : int
            Local index of the target point.
        reach : ndarray of shape (k,), optional
            Largest squared distance of a query's edges.

        Returns
        -------
        ndarray of shape (k,)
            F^j(k) of each query.
        """
        k, m = sq_dist.shape
        s = min(self.n_neighbors, m)
        near = np.argpartition(sq_dist, s - 1, axis=1)[:, :s]  # the query's graph edges
        near_d2 = np.take_along_axis(sq_dist, near, axis=1)
        w = np.exp(near_d2 * (-0.5 / self.sigma**2))
        deg = self.degrees[near]
        w[deg <= TINY] = 0.0
        if reach is not None:
            w[near_d2 > reach[:, None]] = 0.0
        total = w.sum(axis=1)
        out = np.zeros(k)
        rows = np.flatnonzero(total > TINY)
        if rows.size == 0:
            return out
        near, w, deg, total = near[rows], w[rows], deg[rows], total[rows]
        a = self.alpha
        gain = 1.0 / (1.0 - a * self.values) - 1.0 / (1.0 - a * self.col_rest)
        rest = 1.0 / (1.0 - a * self.point_rest)
        Qs = self.vectors[near]  # (k, s, r)
        # H_SS and H_tS from the factors (the diag(e) part only where the indices coincide).
        H_ss = np.einsum("ksr,ktr->kst", Qs * gain, Qs)
        H_ss[:, np.arange(s), np.arange(s)] += rest[near]
        H_ts = Qs @ (gain * self.vectors[target])
        at_t = near == target
        H_ts[at_t] += rest[target]
        root = np.sqrt(w)
        g = root / np.sqrt(np.where(deg > TINY, deg, 1.0))
        system = H_ss * g[:, :, None] * g[:, None, :]
        system[:, np.arange(s), np.arange(s)] += 1.0
        v = np.linalg.solve(system, root[:, :, None])[:, :, 0]
        toward = np.einsum("ks,ks,ks->k", H_ts, g, v)
        d_t = self.degrees[target]
        w_t = np.where(at_t, w, 0.0).sum(axis=1)
        toward *= np.sqrt((d_t + w_t) / (d_t * total))
        gap = np.einsum("ks,ks->k", root, v) / total  # 1 - s^T A^-1 s
        out[rows] = (1.0 - a) * a * toward / (1.0 - a * a + a * a * gap)
        return out


def cluster_model(X, geometry, idx, sigma, alpha, predict_alpha, dtype, tol):
    """Build the eq. 13 model of one cluster and its points' O_d^j (eq. 11) in its own kernel.

    Every cluster of a graph fit gets a
    [`GraphClusterModel`][mapping.manifold.graph_cluster_model.GraphClusterModel] on the graph
    restricted to it (its sigma_j was chosen on the graph kernel), built from the same eigenbasis as
    its O_d^j; a dense fit's clusters the exact
    [`ClusterModel`][mapping.manifold.cluster_model.ClusterModel] of their distances.

    Parameters
    ----------
    X : ndarray of shape (n, d)
        Training data.
    geometry : DenseGeometry or GraphGeometry
        The training geometry.
    idx : ndarray of int
        Training indices of the cluster's points.
    sigma, alpha : float
        The cluster's sigma_j and the alpha its O_d^j is computed with.
    predict_alpha : float
        alpha of the model's eq. 13.
    dtype : numpy.dtype
        Storage dtype of the model's arrays.
    tol : float
        Energy the dense model's basis may leave out (``ClusterModel.build``).

    Returns
    -------
    model : ClusterModel or GraphClusterModel
        The cluster's model, centred on its point of least O_d^j.
    o_j : ndarray of shape (m,)
        O_d^j of the cluster's points.
    """
    if isinstance(geometry, GraphGeometry):
        sub = geometry.node(idx)
        basis = sub.basis(sigma)
        o_j = unit_outliers(basis, basis.gains(np.array([alpha])))[2][:, 0]
        centre = int(np.argmin(o_j))
        model = GraphClusterModel.build(X, sub, basis, sigma, predict_alpha, centre, dtype)
        return model, o_j
    o_j = geometry.sub(idx).outliers(sigma, alpha)
    centre = int(np.argmin(o_j))
    block = geometry.block(idx)
    return ClusterModel.build(X, idx, block, sigma, predict_alpha, centre, dtype, tol), o_j


def model_scores(models, X: np.ndarray, normalize: bool) -> tuple[np.ndarray, np.ndarray]:
    """Return F^j(k) toward each centre and the scaled nearest distances, for a graph fit.

    F^j(k) of eq. 13 toward each centre (k, K), divided by ``scale`` if ``normalize``, and
    ``min_i |x - x_i|^2 / (2 sigma_j^2)`` (k, K): ``Stack.scores`` for a graph fit.

    A query is joined, as a training point is in the fit's graph, to its ``n_neighbors``
    nearest training points over all clusters; a cluster none of them lies in has F = 0.
    Without this a cluster whose sigma_j sits high on the plateau of Omega (on a k-NN graph
    every sigma well above the edge lengths gives nearly the same kernel) would reach queries
    from other manifolds. Rows go in blocks: O(block n) memory, not O(k n). Each block is
    centred, cast and projected once for all clusters (one GEMV over the stacked points of
    `Projection`), not once per cluster.

    Parameters
    ----------
    models : sequence of GraphClusterModel
        One model per cluster.
    X : ndarray of shape (k, d)
        Queries.
    normalize : bool
        Divide F by each model's ``scale``.

    Returns
    -------
    f : ndarray of shape (k, K)
        F^j(k) of each query and cluster.
    nearest : ndarray of shape (k, K)
        ``min_i |x - x_i|^2 / (2 sigma_j^2)`` of each query and cluster.
    """
    k = X.shape[0]
    f = np.empty((k, len(models)))
    nearest = np.empty_like(f)
    n = sum(m.indices.shape[0] for m in models)
    step = max(1, _ROW_ELEMENTS // max(n, 1))
    projection = Projection.of(models, "points")
    starts = projection.starts
    for start in range(0, k, step):
        rows = slice(start, start + step)
        # (x - mean_j) . p_i for every cluster's points, and |x - mean_j|^2
        cross, q = projection(X[rows])
        together = cross
        together *= -2.0
        for j, model in enumerate(models):
            together[:, starts[j] : starts[j + 1]] += q[:, j : j + 1] + model.sq_norms
        np.maximum(together, 0.0, out=together)
        d2 = [together[:, starts[j] : starts[j + 1]] for j in range(len(models))]
        s = min(models[0].n_neighbors, n) - 1
        reach = np.partition(together, s, axis=1)[:, s]
        for j, model in enumerate(models):
            f[rows, j] = model.signal(d2[j], model.centre, reach)
            nearest[rows, j] = d2[j].min(axis=1) * (0.5 / model.sigma**2)
    if normalize:
        f /= np.array([model.scale for model in models])[None, :]
    return f, nearest
