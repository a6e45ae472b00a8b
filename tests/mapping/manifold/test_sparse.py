"""The k-NN graph / low-rank path of ManifoldClustering against the exact dense path."""

import json
from pathlib import Path

import numpy as np
import pytest
import scipy.sparse as sp
from scipy.sparse.csgraph import connected_components
from scipy.sparse.linalg import ArpackError
from sklearn.neighbors import NearestNeighbors

import mapping.manifold.lowrank_kernel as lowrank
from mapping import persistence
from mapping.distances import squared_distances
from mapping.manifold import SYNTHETIC_SETS, ManifoldClustering, branching_sequences
from mapping.manifold.cluster_model import ClusterModel
from mapping.manifold.geometry import GraphGeometry, knn_edges
from mapping.manifold.graph_cluster_model import GraphClusterModel
from mapping.manifold.kernel import SpectralBasis, unit_outliers
from mapping.manifold.lowrank_kernel import LowRankBasis
from mapping.manifold.split import SearchSpace, split_scores
from mapping.manifold.tree import GroupScores, shared_kernel_merge
from mapping.metrics import clustering_error

ALPHAS = np.array([0.5, 0.9, 0.99, 0.9999])


def _dense_from_edges(edges):
    """The same graph as a dense matrix of squared distances, non-edges at infinity."""
    D = np.full(edges.shape, np.inf)
    coo = edges.tocoo()
    D[coo.row, coo.col] = coo.data
    np.fill_diagonal(D, 0.0)
    return D


@pytest.fixture(scope="module")
def lines():
    # a little noise: the exact lines have mirror-image points with equal O_d (seed ties)
    return SYNTHETIC_SETS["parallel_lines"](noise=0.002, rng=np.random.default_rng(0))


def test_knn_edges_are_the_symmetrised_neighbour_graph(lines):
    X, _ = lines
    E = knn_edges(X, 6)
    dist, ind = NearestNeighbors(n_neighbors=6).fit(X).kneighbors()
    for i in (0, 57, 299):
        for j, dd in zip(ind[i], dist[i], strict=True):
            assert E[i, j] == pytest.approx(dd**2, rel=1e-9, abs=1e-15)
            assert E[j, i] == E[i, j]
    assert (E != E.T).nnz == 0
    assert np.diff(E.indptr).min() >= 6


def test_n_neighbors_beyond_n_means_the_complete_graph():
    X = np.random.default_rng(0).normal(size=(12, 3))
    E = knn_edges(X, 50)
    assert E.nnz == 12 * 11
    np.testing.assert_allclose(_dense_from_edges(E), squared_distances(X), rtol=1e-9, atol=1e-12)


def test_untruncated_low_rank_basis_is_the_exact_kernel(lines):
    # rank >= m: every component is decomposed in full, so all of eq. 4-9 must agree with the
    # dense eigenbasis of the same (sparse) S to round-off.
    X, _ = lines
    E = knn_edges(X, 8)
    sigma = 0.03
    low = LowRankBasis.from_edges(E, sigma, rank=X.shape[0])
    exact = SpectralBasis.from_sq_distances(_dense_from_edges(E), sigma)
    g_low, g_ex = low.gains(ALPHAS), exact.gains(ALPHAS)
    np.testing.assert_allclose(low.column_norms(g_low), exact.column_norms(g_ex), rtol=1e-8)
    cols = np.array([3, 150, 299, 7])
    np.testing.assert_allclose(
        low.kernel_columns(g_low, cols), exact.kernel_columns(g_ex, cols), rtol=1e-8, atol=1e-10
    )
    # At alpha = 0.5 the kernel columns fall below round-off (1e-16) a few dozen points from the
    # seeds, and eq. 8's sign there is noise on either path; from alpha = 0.9 on it is not.
    om_low, first_low, seeds_low = split_scores(low, ALPHAS[1:], 20, SearchSpace())
    om_ex, first_ex, seeds_ex = split_scores(exact, ALPHAS[1:], 20, SearchSpace())
    np.testing.assert_allclose(om_low, om_ex, rtol=1e-7, atol=1e-10)
    np.testing.assert_array_equal(first_low, first_ex)
    np.testing.assert_array_equal(seeds_low, seeds_ex)
    member = np.zeros((X.shape[0], 20))
    member[np.arange(X.shape[0]), np.arange(X.shape[0]) % 20] = 1.0  # > _FEW_GROUPS: sparse
    inv_nu = 1.0 / low.column_norms(g_low)[:, 2]
    np.testing.assert_allclose(
        low.group_gram(g_low, 2, member, inv_nu),
        exact.group_gram(g_ex, 2, member, inv_nu),
        rtol=1e-8,
    )


def test_truncated_basis_agrees_with_the_exact_kernel_near_alpha_one():
    # The stated tolerance of the truncation: 1200 views of the benchmark's sequences, 10-NN
    # graph, 64 eigenpairs of S. Near alpha = 1 (where the splits pick alpha) the top of the
    # spectrum carries the kernel: column norms within 2 %, O_d within 0.02.
    X, _ = branching_sequences(150, 50, np.random.default_rng(1))
    E = knn_edges(X, 10)
    sigma = float(np.sqrt(np.median(E.data)))
    low = LowRankBasis.from_edges(E, sigma, rank=64)
    exact = SpectralBasis.from_sq_distances(_dense_from_edges(E), sigma)
    alphas = np.array([0.999, 0.9999])
    g_low, g_ex = low.gains(alphas), exact.gains(alphas)
    np.testing.assert_allclose(low.column_norms(g_low), exact.column_norms(g_ex), rtol=0.02)
    o_low = unit_outliers(low, g_low)[2]
    o_ex = unit_outliers(exact, g_ex)[2]
    np.testing.assert_allclose(o_low, o_ex, atol=0.02)


def test_disconnected_graph_components_each_get_their_kernel():
    # Two blobs far apart and an isolated point: the 5-NN graph has three components; the
    # isolated point's kernel is exactly its own unit column, nothing leaks between blobs.
    rng = np.random.default_rng(2)
    X = np.concatenate([rng.normal(size=(40, 2)), rng.normal(size=(40, 2)) + 100.0, [[-1e4, 0]]])
    E = knn_edges(X, 5)
    E.data[E.data > 1e3] = 0.0  # drop the isolated point's long edges
    E.eliminate_zeros()
    basis = LowRankBasis.from_edges(E, 1.0, rank=8)
    g = basis.gains(np.array([0.99]))
    col = basis.kernel_columns(g, np.array([80]))[:, 0]
    np.testing.assert_allclose(col, np.eye(81)[80], atol=1e-12)
    first = basis.kernel_columns(g, np.array([0]))[:, 0]
    assert np.all(first[40:] == 0.0) and np.all(first[:40] > 0)
    assert basis.column_norms(g).min() > 0


def test_geometry_turns_dense_below_the_threshold(lines):
    X, _ = lines
    geo = GraphGeometry(X, knn_edges(X, 8), np.arange(X.shape[0]), rank=8, dense_below=50)
    small = geo.sub(np.arange(40))
    np.testing.assert_allclose(small.sq_dist, squared_distances(X[:40]))
    assert isinstance(geo.sub(np.arange(100)), GraphGeometry)
    assert sp.issparse(geo.sub(np.arange(100)).edges)


@pytest.mark.parametrize("name", ["parallel_lines", "spirals_3d"])
def test_sparse_path_clusters_like_the_dense_path(name):
    X, y = SYNTHETIC_SETS[name]()
    # n_components=16 sends every node above 64 points through the truncated basis (with 8,
    # converging paths loses 29 % of its points: docs/decisions/006-dense-or-graph-kernel.md).
    sparse = ManifoldClustering(3, 20, kernel="sparse", n_components=16).fit(X)
    dense = ManifoldClustering(3, 20, kernel="dense").fit(X)
    assert clustering_error(y, sparse.labels_) <= clustering_error(y, dense.labels_)
    assert sparse.predict(X[::7]).shape == (len(X[::7]),)


def test_auto_keeps_small_fits_on_the_dense_path(lines):
    X, _ = lines
    auto = ManifoldClustering(3, 20).fit(X)
    dense = ManifoldClustering(3, 20, kernel="dense").fit(X)
    np.testing.assert_array_equal(auto.labels_, dense.labels_)
    np.testing.assert_array_equal(auto.outlier_scores_, dense.outlier_scores_)


def test_sparse_path_accepts_n_neighbors_beyond_n_and_rejects_zero():
    X, y = SYNTHETIC_SETS["parallel_lines"](n_per_line=30)
    model = ManifoldClustering(3, 10, kernel="sparse", n_neighbors=500, n_components=4).fit(X)
    assert clustering_error(y, model.labels_) == 0.0
    with pytest.raises(ValueError, match="n_neighbors"):
        ManifoldClustering(3, 10, kernel="sparse", n_neighbors=0).fit(X)
    with pytest.raises(ValueError, match="kernel"):
        ManifoldClustering(3, 10, kernel="lowrank").fit(X)


def test_graph_cluster_model_is_eq13_when_nothing_is_cut():
    # Complete graph, every eigenpair kept, the query joined to every point: the low-rank
    # Woodbury form must be the exact eq. 13 of the dense model (and the same column scale).
    rng = np.random.default_rng(0)
    t = np.linspace(0, 1, 40)
    X = np.c_[t, np.sin(3 * t)] + rng.normal(0, 0.01, (40, 2))
    geo = GraphGeometry(X, knn_edges(X, 40), np.arange(40), rank=40, dense_below=0, n_neighbors=40)
    basis = LowRankBasis.from_edges(geo.edges, 0.1, rank=40)
    graph = GraphClusterModel.build(X, geo, basis, 0.1, 0.99, 5, np.dtype(np.float64))
    dense = ClusterModel.build(X, np.arange(40), squared_distances(X), 0.1, 0.99, 5, np.float64)
    Q = np.c_[t[::3] + 0.01, np.sin(3 * t[::3]) + 0.02]
    f_graph = graph.signal(graph.sq_distances(Q), 5)
    f_dense = dense.signal(dense.sq_distances(Q), 5)
    np.testing.assert_allclose(f_graph, f_dense, rtol=1e-9)
    assert graph.scale == pytest.approx(dense.scale, rel=1e-9)
    # A query farther than every training point's reach gets exactly 0.
    assert graph.signal(graph.sq_distances(np.array([[1e3, 1e3]])), 5)[0] == 0.0


@pytest.mark.parametrize("name", ["parallel_lines", "lines_variable_spacing"])
def test_graph_fit_predicts_its_own_training_labels(name):
    # predict joins a point to its k nearest training points of all clusters (the fit's graph):
    # the training points themselves must get their own clusters back.
    X, y = SYNTHETIC_SETS[name]()
    model = ManifoldClustering(3, 20, kernel="sparse").fit(X)
    assert all(isinstance(m, GraphClusterModel) for m in model._models)
    assert clustering_error(y, model.labels_) == 0.0
    np.testing.assert_array_equal(model.predict(X), model.labels_)
    proba = model.predict_proba(X[::9])
    np.testing.assert_allclose(proba.sum(axis=1), 1.0)


def test_graph_fit_with_a_disconnected_graph():
    # Three lines 1 apart with 5 neighbours: the graph has three components (no edge between
    # lines). Each split, the merge and every cluster's kernel work per component.
    X, y = SYNTHETIC_SETS["parallel_lines"](n_per_line=60)
    X = X * np.array([1.0, 10.0])
    E = knn_edges(X, 5)
    assert connected_components(E, directed=False)[0] == 3
    model = ManifoldClustering(3, 10, kernel="sparse", n_neighbors=5, n_components=8).fit(X)
    assert clustering_error(y, model.labels_) == 0.0
    np.testing.assert_array_equal(model.predict(X), model.labels_)


def test_shared_kernel_merge_joins_the_pieces_of_each_line():
    # The scalable merge reads every pair's spread from one set of block sums: 3 lines cut
    # into 12 leaves become the 3 lines.
    X, y = SYNTHETIC_SETS["parallel_lines"](noise=0.002, rng=np.random.default_rng(0))
    geo = GraphGeometry(X, knn_edges(X, 10), np.arange(X.shape[0]), rank=32, dense_below=64)
    leaves = [
        np.flatnonzero((y == c) & (np.arange(len(y)) % 100 // 25 == q))
        for c in range(3)
        for q in range(4)
    ]
    space = geo.search_space(SearchSpace())
    groups = shared_kernel_merge(geo, leaves, 3, GroupScores(geo, leaves, space))
    assert sorted(map(sorted, groups)) == [[0, 1, 2, 3], [4, 5, 6, 7], [8, 9, 10, 11]]


def test_graph_search_uses_the_dense_grid_without_sigma_refinement_and_reuses_its_bases(lines):
    # A graph node searches the dense path's n_sigmas grid, refining alpha but not sigma; the
    # combination uses that grid to the last bit, so the root's bases are computed once
    # (memory O(n_sigmas m r)) and every sigma the combination asks for is one of them.
    X, _ = lines
    geo = GraphGeometry(X, knn_edges(X, 10), np.arange(X.shape[0]), rank=16, dense_below=64)
    space = SearchSpace(n_sigmas=9)
    assert geo.search_space(space).n_sigmas == 9 and not geo.search_space(space).refine_sigma
    assert geo.search_space(space).refine
    lo, hi = geo.sigma_bounds()
    split = [float(np.exp(v)) for v in np.linspace(np.log(lo), np.log(hi), 9)]
    kept = {sigma: geo.basis(sigma) for sigma in split}
    scores = GroupScores(geo, [np.arange(150), np.arange(150, X.shape[0])], space)
    assert scores.sigmas.tolist() == split
    assert all(geo.basis(sigma) is kept[sigma] for sigma in split)
    assert set(geo._bases) == set(split)


def test_graph_fit_round_trips_through_persistence():
    X, _ = SYNTHETIC_SETS["parallel_lines"](n_per_line=40)
    model = ManifoldClustering(3, 10, kernel="sparse", n_components=8).fit(X)
    meta, arrays = persistence.dump(model, "m")
    loaded = persistence.load(ManifoldClustering, json.loads(json.dumps(meta)), arrays, "m")
    assert meta["records"]["_models"]["class"] == "GraphClusterModel"
    np.testing.assert_array_equal(loaded.predict(X), model.predict(X))
    np.testing.assert_array_equal(loaded.signal(X, 1), model.signal(X, 1))


def test_top_eigenpairs_survive_arpack_error_3_on_a_nearly_disconnected_node():
    # A 675-point node of a fit of 1350 pooled image frames (dataset seeds 270-272) at a small
    # sigma: 119 eigenvalues of S within 1e-6 of 1. ARPACK with a space of k + 16 stopped there
    # with "error 3: no shifts could be applied" and the fit crashed; the solve is repeated
    # with twice the space. The top 64 are a few of the 119 (all within 3e-13 of 1): what
    # Lanczos returns there are true eigenpairs of that cluster, not necessarily the exact 64.
    block = sp.load_npz(Path(__file__).parent / "fixtures" / "arpack_no_shifts_block.npz")
    block = block.tocsr()
    lam, q = lowrank._top_eigenpairs(block, 64)
    assert lam.shape == (64,) and q.shape == (675, 64)
    assert np.sum(np.linalg.eigvalsh(block.toarray()) > 1 - 1e-6) == 119
    # which pairs Lanczos settles on in that cluster depends on the BLAS: all within 1e-5
    # of 1 with numpy 2's OpenBLAS, down to 0.99991 with numpy 1.26's (gtsam 4.2 needs it)
    assert lam.min() > 1 - 1e-3
    np.testing.assert_allclose(q.T @ q, np.eye(64), atol=1e-10)
    assert np.abs(block @ q - q * lam).max() < 1e-10


def test_top_eigenpairs_retry_then_fall_back_to_dense(monkeypatch):
    # Control flow without ARPACK's judgement: error 3 on the first space (k + 16) -> one
    # retry with twice it; failing again -> the dense decomposition (a small block).
    rng = np.random.default_rng(0)
    A = sp.random(60, 60, density=0.2, random_state=rng)
    block = ((A + A.T) * 0.5).tocsr()
    calls = []

    def failing(*args, ncv, **kwargs):
        calls.append(ncv)
        raise ArpackError(3)

    monkeypatch.setattr(lowrank, "eigsh", failing)
    lam, _ = lowrank._top_eigenpairs(block, 5)
    assert calls == [21, 42]
    np.testing.assert_allclose(lam, np.linalg.eigvalsh(block.toarray())[-5:], atol=1e-12)
