"""Recursive min-Ncut partition (Blanco et al., eq. 1, 10-13) and the scan estimator."""

import numpy as np
import pytest
import scipy.sparse as sp
import scipy.sparse.linalg
from sklearn.base import clone
from sklearn.exceptions import NotFittedError
from sklearn.utils._param_validation import InvalidParameterError
from sklearn.utils.validation import check_is_fitted

from mapping.grouping import office_path, office_world, raycast
from mapping.grouping.normalized_cut import ncut, recursive_ncut_partition, spectral_bisection
from mapping.grouping.partitioner import ObservationGraphPartitioner
from mapping.metrics import purity
from tests.mapping.grouping.weighted_graphs import UNEVEN

EPS = 0.1  # the weak edge between the cliques


def two_cliques(eps: float = EPS) -> np.ndarray:
    """Two unit-weight triangles {0, 1, 2} and {3, 4, 5}, unit diagonal, edge 2-3 of ``eps``."""
    W = np.zeros((6, 6))
    W[:3, :3] = 1.0
    W[3:, 3:] = 1.0
    W[2, 3] = W[3, 2] = eps
    return W


def clique(n: int, w: float) -> np.ndarray:
    W = np.full((n, n), w)
    np.fill_diagonal(W, 1.0)
    return W


MASK = np.array([True, True, True, False, False, False])


def test_ncut_by_hand():
    W = two_cliques()
    # mrpt: cut = 0.1, assoc(A, A) = 3 pairs of weight 1, assoc(A, V) = 3.1
    assert ncut(W, MASK) == pytest.approx(2 * EPS / 3.1)
    # paper (eq. 3): assoc(A, V) = degrees 3 + 3 + 3.1 = 9.1
    assert ncut(W, MASK, assoc="paper") == pytest.approx(2 * EPS / 9.1)
    # the worst cut (eq. 7): a bipartite graph across the bisection scores 2 under both
    bip = np.array([[0.0, 1.0], [1.0, 0.0]])
    assert ncut(bip, [True, False]) == pytest.approx(2.0)
    assert ncut(bip, [True, False], assoc="paper") == pytest.approx(2.0)


@pytest.mark.parametrize("laplacian", ["normalized", "unnormalized"])
@pytest.mark.parametrize("solver", ["dense", "sparse"])
def test_bisection_finds_the_cliques(laplacian, solver):
    mask, y = spectral_bisection(two_cliques(), laplacian=laplacian, solver=solver)
    np.testing.assert_array_equal(mask, MASK)
    assert y.shape == (6,)


def test_recursive_partition_reports_the_ncut():
    labels, tree = recursive_ncut_partition(two_cliques())
    np.testing.assert_array_equal(labels, [0, 0, 0, 1, 1, 1])
    assert tree.accepted and tree.ncut == pytest.approx(2 * EPS / 3.1)
    # each triangle is a clique: its best bisection is proposed but rejected
    for leaf in tree.children:
        assert not leaf.accepted and leaf.ncut >= 1.0


@pytest.mark.parametrize("w", [0.3, 0.8, 1.0])
def test_clique_is_not_split_under_threshold_one(w):
    labels, tree = recursive_ncut_partition(clique(12, w))
    assert labels.max() == 0
    assert not tree.accepted and tree.ncut > 1.0


def test_paper_assoc_splits_any_clique_weaker_than_one():
    # why "mrpt" is the default: with eq. 3's volume and a unit diagonal a clique of weight
    # w < 1 has Ncut = n w / (1 + (n - 1) w) < 1 for every bisection
    n, w = 12, 0.8
    mask = np.arange(n) < 5
    assert ncut(clique(n, w), mask, assoc="paper") == pytest.approx(n * w / (1 + (n - 1) * w))
    labels, _ = recursive_ncut_partition(clique(n, w), assoc="paper")
    assert labels.max() == n - 1


def test_disconnected_graph_splits_along_components():
    W = sp.block_diag([clique(4, 0.5), clique(3, 0.5), clique(5, 0.5)]).toarray()
    mask, _ = spectral_bisection(W)
    np.testing.assert_array_equal(mask, np.arange(12) < 4)
    labels, tree = recursive_ncut_partition(W)
    np.testing.assert_array_equal(labels, np.repeat([0, 1, 2], [4, 3, 5]))
    assert tree.ncut == 0.0


def block_graph(rng: np.random.Generator, sizes=(60, 80, 70), p_in=0.5, p_out=0.02):
    n = sum(sizes)
    truth = np.repeat(np.arange(len(sizes)), sizes)
    p = np.where(truth[:, None] == truth[None, :], p_in, p_out)
    W = np.triu((rng.random((n, n)) < p) * rng.uniform(0.2, 1.0, (n, n)), 1)
    W = W + W.T + np.eye(n)
    return W, truth


def test_dense_and_sparse_solvers_agree():
    W, truth = block_graph(np.random.default_rng(0))
    dense, _ = recursive_ncut_partition(W, solver="dense")
    sparse, _ = recursive_ncut_partition(sp.csr_array(W), solver="sparse")
    np.testing.assert_array_equal(dense, sparse)
    assert purity(truth, dense) == 1.0 and dense.max() == 2


def test_threshold_and_min_size():
    assert recursive_ncut_partition(two_cliques(), threshold=0.0)[0].max() == 0
    assert recursive_ncut_partition(two_cliques(), min_size=4)[0].max() == 0


def test_single_node():
    labels, tree = recursive_ncut_partition(np.ones((1, 1)))
    np.testing.assert_array_equal(labels, [0])
    assert tree.ncut is None and not tree.accepted


def test_rejects_bad_graphs():
    with pytest.raises(ValueError, match="square"):
        recursive_ncut_partition(np.ones((2, 3)))
    with pytest.raises(ValueError, match="non-negative"):
        recursive_ncut_partition(-two_cliques())
    with pytest.raises(ValueError, match="symmetric"):
        recursive_ncut_partition(np.triu(two_cliques()))
    with pytest.raises(ValueError, match="NaN"):
        recursive_ncut_partition(np.full((2, 2), np.nan))
    with pytest.raises(ValueError, match="threshold"):
        recursive_ncut_partition(two_cliques(), threshold=3.0)
    with pytest.raises(ValueError, match="assoc must be one of"):
        recursive_ncut_partition(two_cliques(), assoc="twice")
    with pytest.raises(ValueError, match="at least 2 nodes"):
        spectral_bisection(np.ones((1, 1)))
    with pytest.raises(ValueError, match="each side"):
        ncut(two_cliques(), np.ones(6, bool))
    with pytest.raises(ValueError, match="mask must have shape"):
        ncut(two_cliques(), np.ones(5, bool))


# --------------------------------------------------------------------------- the estimator


@pytest.fixture(scope="module")
def office():
    world = office_world()
    poses = office_path(world, step=1.17)
    return world, raycast(world.segments, poses), poses


def test_groups_the_office_by_rooms(office):
    world, scans, poses = office
    model = ObservationGraphPartitioner().fit(scans, poses)
    truth = world.region_labels(poses)
    assert model.labels_.shape == (len(scans),)
    assert purity(truth, model.labels_) >= 0.9
    for room in range(world.n_rooms):
        # most of each room's scans land in one group, and no room splits into > 3 groups
        groups, counts = np.unique(model.labels_[truth == room], return_counts=True)
        assert len(groups) <= 3 and counts.max() >= 0.8 * counts.sum()
    # the learned state is consistent
    assert model.n_groups_ == model.labels_.max() + 1 == len(model.local_maps_)
    assert len(model.split_tree_.leaves()) == model.n_groups_
    assert all(n.ncut < 1.0 for n in model.split_tree_.walk() if n.accepted)


def test_fit_is_deterministic(office):
    _, scans, poses = office
    a = ObservationGraphPartitioner().fit(scans, poses)
    b = ObservationGraphPartitioner().fit(scans, poses)
    np.testing.assert_array_equal(a.labels_, b.labels_)
    np.testing.assert_array_equal(a.affinity_matrix_.toarray(), b.affinity_matrix_.toarray())


def test_precomputed_affinity_is_the_same_partition(office):
    _, scans, poses = office
    model = ObservationGraphPartitioner().fit(scans, poses)
    other = ObservationGraphPartitioner(affinity="precomputed")
    other.fit(model.affinity_matrix_.toarray())
    np.testing.assert_array_equal(other.labels_, model.labels_)
    labels, _ = recursive_ncut_partition(model.affinity_matrix_)
    np.testing.assert_array_equal(labels, model.labels_)


def test_empty_scans_follow_their_neighbours(office):
    _, scans, poses = office
    scans = list(scans)
    full = ObservationGraphPartitioner().fit(scans, poses).labels_
    for i in (0, 20, 21):
        scans[i] = np.empty((0, 2))
    nearest = ObservationGraphPartitioner().fit(scans, poses).labels_
    assert nearest[0] == nearest[1] and nearest[20] == nearest[19] and nearest[21] == nearest[22]
    noise = ObservationGraphPartitioner(empty_scans="noise").fit(scans, poses).labels_
    np.testing.assert_array_equal(np.flatnonzero(noise < 0), [0, 20, 21])
    # the scans with points are partitioned the same way in both modes, and much as before
    np.testing.assert_array_equal(noise[noise >= 0], nearest[noise >= 0])
    assert purity(full[noise >= 0], noise[noise >= 0]) >= 0.9


def test_single_scan_and_all_empty():
    model = ObservationGraphPartitioner().fit([np.ones((5, 2))], np.zeros((1, 3)))
    np.testing.assert_array_equal(model.labels_, [0])
    assert model.topology_.arcs == [] and len(model.local_maps_) == 1
    empty = ObservationGraphPartitioner().fit([np.empty((0, 2))] * 3, np.zeros((3, 3)))
    np.testing.assert_array_equal(empty.labels_, [0, 0, 0])


def test_estimator_rejects_bad_input(office):
    _, scans, poses = office
    with pytest.raises(ValueError, match="same length"):
        ObservationGraphPartitioner().fit(scans, poses[:-1])
    with pytest.raises(ValueError, match="match_distance"):
        ObservationGraphPartitioner(match_distance=0.0).fit(scans, poses)
    with pytest.raises(ValueError, match="match_distance"):
        ObservationGraphPartitioner(match_distance=-1.0).fit(scans, poses)
    with pytest.raises(ValueError, match="empty_scans"):
        ObservationGraphPartitioner(empty_scans="drop").fit(scans, poses)
    bad = np.array(poses)
    bad[3, 2] = np.nan
    with pytest.raises(ValueError, match="poses contains NaN"):
        ObservationGraphPartitioner().fit(scans, bad)


def test_groups_keep_runs_apart(office):
    """Two drives of the same place grouped together: no ICP chaining across the boundary and
    empty scans take their group from their own run."""
    _, scans, poses = office
    n = len(scans)
    both_scans = list(scans) + list(scans)
    both_poses = np.concatenate([poses, poses])
    both_scans[n] = np.empty((0, 2))  # first scan of the second run
    model = ObservationGraphPartitioner(scan_matching=True)
    groups = np.repeat(["first", "second"], n)  # any labels, as in scikit-learn's GroupKFold
    labels = model.fit(both_scans, both_poses, groups=groups).labels_
    # the second run starts where it was given, not chained from the end of the first
    np.testing.assert_array_equal(model.poses_[n], poses[0])
    assert labels[n - 1] != labels[n + 1]  # the two ends are different places
    assert labels[n] == labels[n + 1]
    # without groups the empty scan joins the end of the first run (the tie goes earlier)
    chained = ObservationGraphPartitioner().fit(both_scans, both_poses).labels_
    assert chained[n] == chained[n - 1]
    with pytest.raises(ValueError, match="one label per sample"):
        ObservationGraphPartitioner().fit(scans, poses, groups=[0] * (n - 1))
    with pytest.raises(ValueError, match="consecutive"):
        ObservationGraphPartitioner().fit(both_scans, both_poses, groups=np.arange(2 * n) % 2)


# --------------------------------------------------------------------------- scikit-learn API


def test_params_clone_and_not_fitted(office):
    _, scans, poses = office
    model = ObservationGraphPartitioner(threshold=0.8, scan_matching=False)
    params = model.get_params()
    assert params["threshold"] == 0.8 and params["affinity"] == "sso"
    twin = clone(model)
    assert twin is not model and twin.get_params() == params
    with pytest.raises(NotFittedError):
        check_is_fitted(twin)
    twin.set_params(threshold=1.0).fit(scans, poses)
    check_is_fitted(twin)
    reference = ObservationGraphPartitioner(scan_matching=False).fit(scans, poses)
    np.testing.assert_array_equal(twin.labels_, reference.labels_)
    assert not hasattr(clone(twin), "labels_")  # clone copies parameters, not the fit
    np.testing.assert_array_equal(
        ObservationGraphPartitioner(scan_matching=False).fit_predict(scans, poses),
        reference.labels_,
    )


@pytest.mark.parametrize(
    ("params", "match"),
    [
        ({"threshold": 3.0}, "'threshold' parameter"),
        ({"match_distance": float("nan")}, "'match_distance' parameter"),
        ({"affinity": "cosine"}, "'affinity' parameter"),
        ({"min_size": 0}, "'min_size' parameter"),
        ({"solver": "lobpcg"}, "'solver' parameter"),
        ({"scan_matching": "yes"}, "'scan_matching' parameter"),
    ],
)
def test_parameters_are_validated_by_scikit_learn(office, params, match):
    _, scans, poses = office
    with pytest.raises(InvalidParameterError, match=match):
        ObservationGraphPartitioner(**params).fit(scans, poses)


def test_precomputed_affinity_input():
    model = ObservationGraphPartitioner(affinity="precomputed")
    np.testing.assert_array_equal(model.fit_predict(sp.csr_array(two_cliques())), MASK == 0)
    assert model.n_groups_ == 2 and model.__sklearn_tags__().input_tags.pairwise
    assert not hasattr(model, "topology_")  # no poses: no local maps, no topology
    with pytest.raises(ValueError, match="not used with affinity='precomputed'"):
        model.fit(two_cliques(), np.zeros((6, 3)))
    with pytest.raises(ValueError, match="precomputed affinity.*symmetric"):
        model.fit(np.triu(two_cliques()))
    with pytest.raises(ValueError, match="poses is required"):
        ObservationGraphPartitioner().fit([np.ones((3, 2))])


def test_lobpcg_falls_back_to_arpack(monkeypatch):
    W, truth = block_graph(np.random.default_rng(1))
    calls = []
    eigsh = scipy.sparse.linalg.eigsh
    monkeypatch.setattr(
        scipy.sparse.linalg, "eigsh", lambda *a, **k: calls.append(1) or eigsh(*a, **k)
    )
    lobpcg, _ = recursive_ncut_partition(sp.csr_array(W), solver="sparse")
    assert not calls  # LOBPCG converged on every bisection
    # not converged: ARPACK takes over
    monkeypatch.setattr("mapping.grouping.normalized_cut._LOBPCG_MAXITER", 1)
    arpack, _ = recursive_ncut_partition(sp.csr_array(W), solver="sparse")
    assert calls
    np.testing.assert_array_equal(lobpcg, arpack)
    assert purity(truth, arpack) == 1.0


def test_large_graphs_take_the_sparse_index_path(monkeypatch):
    W, _ = block_graph(np.random.default_rng(2))
    dense, _ = recursive_ncut_partition(W)
    monkeypatch.setattr("mapping.grouping.normalized_cut.DENSE_INDEX_MAX_NODES", 10)
    monkeypatch.setattr("mapping.grouping.normalized_cut.DENSE_MAX_NODES", 50)
    np.testing.assert_array_equal(recursive_ncut_partition(sp.csr_array(W))[0], dense)


def test_voxel_size(office):
    _, scans, poses = office
    exact = ObservationGraphPartitioner(voxel_size=None, scan_matching=False).fit(scans, poses)
    fast = ObservationGraphPartitioner(scan_matching=False).fit(scans, poses)  # "auto"
    np.testing.assert_array_equal(fast.labels_, exact.labels_)
    assert abs(fast.affinity_matrix_ - exact.affinity_matrix_).max() < 0.05
    with pytest.raises(ValueError, match="voxel_size .* must not exceed match_distance"):
        ObservationGraphPartitioner(voxel_size=0.2).fit(scans, poses)


def test_tiny_match_distance_and_voxel_size(office):
    # match_distance=1e-9: a voxel grid 8e10 cells across, whose int64 ids overflowed
    _, scans, poses = office
    with np.errstate(over="raise", invalid="raise"):
        tiny = ObservationGraphPartitioner(scan_matching=False, match_distance=1e-9)
        tiny.fit(scans, poses)
    exact = ObservationGraphPartitioner(scan_matching=False, match_distance=1e-9, voxel_size=None)
    np.testing.assert_array_equal(tiny.labels_, exact.fit(scans, poses).labels_)
    # a voxel 1e8 times finer than the tolerance: refused before the scan matching
    with pytest.raises(ValueError, match="voxel_size must be at least delta / 50"):
        ObservationGraphPartitioner(voxel_size=1e-9).fit(scans, poses)
    with pytest.raises(ValueError, match="voxel_size must be at least delta / 50"):
        ObservationGraphPartitioner(voxel_size=1e-9).partial_fit(scans[:1], poses[:1])


def test_weights_near_the_float_maximum():
    # the degree sums overflowed to inf; the Ncut does not depend on the scale of W
    W = two_cliques()
    labels, tree = recursive_ncut_partition(W)
    big_labels, big_tree = recursive_ncut_partition(W * 1e308)
    np.testing.assert_array_equal(big_labels, labels)
    assert big_tree.ncut == pytest.approx(tree.ncut)
    assert ncut(W * 1e308, MASK) == pytest.approx(ncut(W, MASK))
    np.testing.assert_array_equal(spectral_bisection(W * 1e308)[0], spectral_bisection(W)[0])
    model = ObservationGraphPartitioner(affinity="precomputed")
    np.testing.assert_array_equal(model.fit_predict(np.full((4, 4), 1e308)), [0, 0, 0, 0])
    np.testing.assert_array_equal(model.fit_predict(sp.csr_array(W * 1e308)), labels)


def test_fit_without_x_names_it():
    with pytest.raises(ValueError, match=r"X must be the scans.*got None"):
        ObservationGraphPartitioner().fit(None, np.zeros((3, 3)))
    with pytest.raises(ValueError, match=r"X must be the \(N, N\) weight matrix W.*got None"):
        ObservationGraphPartitioner(affinity="precomputed").fit(None)
    with pytest.raises(ValueError, match=r"X must be the scans.*got None"):
        ObservationGraphPartitioner().partial_fit(None, np.zeros((1, 3)))


# --------------------------------------------------------------------------- boundaries


def test_ncut_and_bisection_errors_name_the_argument():
    with pytest.raises(ValueError, match=r"^assoc must be one of \('mrpt', 'paper'\), got 'x'$"):
        ncut(two_cliques(), MASK, assoc="x")
    with pytest.raises(ValueError, match="^mask must put at least one node on each side of the "):
        ncut(two_cliques(), np.ones(6, bool))
    with pytest.raises(ValueError, match="^laplacian must be one of .*, got 'x'$"):
        spectral_bisection(two_cliques(), laplacian="x")


def test_a_mask_is_read_as_truth_values():
    assert ncut(two_cliques(), [2, 2, 5, 0, 0, 0]) == ncut(two_cliques(), MASK)


def test_two_nodes_are_bisected():
    mask, _ = spectral_bisection(np.array([[0.0, 1.0], [1.0, 0.0]]))
    np.testing.assert_array_equal(mask, [True, False])


def test_the_normalized_bisection_solves_eq_10():
    # a path with unequal degrees: (D - W) y = lambda D y holds, (D - W) y = lambda y does not
    W = np.diag([1.0, 3.0, 0.5, 2.0], 1)  # 5 nodes
    W = W + W.T
    D = np.diag(W.sum(axis=1))
    for laplacian, B in (("normalized", D), ("unnormalized", np.eye(5))):
        _, y = spectral_bisection(W, laplacian=laplacian)
        lam = y @ (D - W) @ y / (y @ B @ y)
        np.testing.assert_allclose((D - W) @ y, lam * B @ y, atol=1e-9)


def test_precomputed_fit_boundaries():
    model = ObservationGraphPartitioner(affinity="precomputed")
    with pytest.raises(ValueError) as info:
        model.fit(two_cliques(), groups=np.zeros(6))
    assert str(info.value) == (
        "poses and groups are not used with affinity='precomputed'; pass only the weight "
        "matrix: fit(W)"
    )
    with pytest.raises(ValueError, match=r"^X \(the precomputed affinity\) has no nodes$"):
        model.fit(np.zeros((0, 0)))
    with pytest.raises(ValueError, match=r"^X \(the precomputed affinity\)"):
        model.fit(-two_cliques())
    np.testing.assert_array_equal(model.fit_predict(np.ones((1, 1))), [0])
    W = two_cliques()
    np.testing.assert_array_equal(model.fit(W).affinity_matrix_.toarray(), W)


def test_tags_follow_the_affinity():
    tags = ObservationGraphPartitioner(affinity="precomputed").__sklearn_tags__().input_tags
    assert (tags.pairwise, tags.sparse, tags.two_d_array) == (True, True, True)
    tags = ObservationGraphPartitioner().__sklearn_tags__().input_tags
    assert (tags.pairwise, tags.sparse, tags.two_d_array) == (False, False, False)


def test_a_precomputed_refit_forgets_the_scans_fit(office):
    _, scans, poses = office
    model = ObservationGraphPartitioner(scan_matching=False).fit(scans, poses)
    assert hasattr(model, "poses_") and hasattr(model, "topology_")
    model.set_params(affinity="precomputed").fit(two_cliques())
    assert not any(hasattr(model, a) for a in ("poses_", "local_maps_", "topology_"))


def test_fit_predict_passes_the_groups_on(office):
    # as in test_groups_keep_runs_apart: with the runs given, the second run's empty first
    # scan joins its own run, without them the end of the first
    _, scans, poses = office
    n = len(scans)
    both_scans = list(scans) + list(scans)
    both_scans[n] = np.empty((0, 2))
    groups = np.repeat(["first", "second"], n)
    model = ObservationGraphPartitioner(scan_matching=True)
    labels = model.fit_predict(both_scans, np.concatenate([poses, poses]), groups=groups)
    assert labels[n] == labels[n + 1] != labels[n - 1]


def test_the_recursion_bisects_with_the_chosen_laplacian():
    splits = {}
    for laplacian in ("normalized", "unnormalized"):
        mask, _ = spectral_bisection(UNEVEN, laplacian=laplacian)
        _, tree = recursive_ncut_partition(UNEVEN, threshold=2.0, laplacian=laplacian)
        np.testing.assert_array_equal(tree.children[0].indices, np.flatnonzero(mask))
        splits[laplacian] = tuple(mask)
    assert splits["normalized"] != splits["unnormalized"]


def test_a_bisection_holds_node_0_and_its_side_of_the_eigenvector():
    order = [3, 0, 4, 1, 5, 2]  # node 0 of this graph is in the second clique, node 1 in the first
    W = two_cliques()[np.ix_(order, order)]
    mask, y = spectral_bisection(W)
    np.testing.assert_array_equal(mask, [True, False, True, False, True, False])
    np.testing.assert_array_equal(mask, y >= y.mean())
    # disconnected: y is the indicator of node 0's component
    order = [0, 2, 1, 3]
    W = sp.block_diag([clique(2, 0.5), clique(2, 0.5)]).toarray()[np.ix_(order, order)]
    mask, y = spectral_bisection(W)
    np.testing.assert_array_equal(y, [1.0, 0.0, 1.0, 0.0])
    two = sp.block_diag([clique(3, 0.5), clique(3, 0.5)]).toarray()
    np.testing.assert_array_equal(spectral_bisection(two)[1], [1, 1, 1, 0, 0, 0])


def test_a_singleton_group_does_not_stop_the_recursion():
    W = sp.block_diag([np.ones((1, 1)), clique(3, 0.5), clique(3, 0.5)]).toarray()
    labels, _ = recursive_ncut_partition(W)
    np.testing.assert_array_equal(labels, [0, 1, 1, 1, 2, 2, 2])


def test_threshold_and_min_size_at_their_edges():
    at = ncut(two_cliques(), MASK)
    assert recursive_ncut_partition(two_cliques(), threshold=at)[0].max() == 0  # Ncut < threshold
    assert recursive_ncut_partition(two_cliques(), threshold=np.nextafter(at, 1))[0].max() == 1
    assert recursive_ncut_partition(two_cliques(), threshold=2.0)[0].max() >= 1
    # a clique of 4 (node 0's) and one of 2: the smaller side decides
    W = np.zeros((6, 6))
    W[:4, :4] = W[4:, 4:] = 1.0
    W[3, 4] = W[4, 3] = EPS
    assert recursive_ncut_partition(W, min_size=2)[0].max() == 1
    assert recursive_ncut_partition(W, min_size=3)[0].max() == 0
    with pytest.raises(ValueError, match="^min_size must be a positive integer, got 0$"):
        recursive_ncut_partition(W, min_size=0)
    with pytest.raises(ValueError, match="^laplacian must be one of"):
        recursive_ncut_partition(W, laplacian="x")
    with pytest.raises(ValueError, match="^W has no nodes$"):
        recursive_ncut_partition(np.zeros((0, 0)))


def test_small_blocks_of_a_large_sparse_graph_are_solved_dense(monkeypatch):
    W, _ = block_graph(np.random.default_rng(2))
    dense, _ = recursive_ncut_partition(W)
    monkeypatch.setattr("mapping.grouping.normalized_cut.DENSE_INDEX_MAX_NODES", 10)
    monkeypatch.setattr("mapping.grouping.normalized_cut.DENSE_MAX_NODES", 100)
    np.testing.assert_array_equal(recursive_ncut_partition(sp.csr_array(W))[0], dense)


def test_defaults_labels_and_messages_of_the_estimator(office):
    _, scans, poses = office
    params = ObservationGraphPartitioner().get_params()
    assert (params["min_size"], params["scan_matching"]) == (1, True)
    model = ObservationGraphPartitioner(scan_matching=False, min_size=len(scans))
    assert model.fit(scans, poses).n_groups_ == 1  # min_size reaches the recursion
    assert model.labels_.dtype == np.intp
    with pytest.raises(ValueError, match=r"^poses is required with affinity='sso': fit\(scans, "):
        ObservationGraphPartitioner().fit(scans)
    with pytest.raises(ValueError, match=r"^X must be the scans, a sequence of \(M_i, 2\) point"):
        ObservationGraphPartitioner().fit(None, poses)
    with pytest.raises(ValueError, match="^solver must be one of"):
        spectral_bisection(two_cliques(), solver="x")
    with pytest.raises(ValueError, match="^W must be a square matrix"):
        ncut(np.ones((2, 3)), [True, False])
    labels, _ = recursive_ncut_partition(two_cliques())
    assert labels.dtype == np.intp


def test_a_fit_ends_a_partial_fit_sequence(office):
    _, scans, poses = office
    model = ObservationGraphPartitioner(scan_matching=False).partial_fit(scans[:5], poses[:5])
    model.fit(scans, poses)
    with pytest.raises(ValueError, match="fitted with fit"):
        model.partial_fit(scans[:5], poses[:5])


def test_voxel_size_at_the_match_distance_and_far_below(office):
    _, scans, poses = office
    ObservationGraphPartitioner(scan_matching=False, match_distance=0.1, voxel_size=0.1).fit(
        scans, poses
    )
    with pytest.raises(ValueError, match="must not exceed match_distance .*tells apart$"):
        ObservationGraphPartitioner(match_distance=0.1, voxel_size=0.2).fit(scans, poses)
    with pytest.raises(ValueError):
        ObservationGraphPartitioner(match_distance=0.1, voxel_size=1e-9).fit(scans, poses)


def test_one_point_scans_are_nodes_and_the_tree_counts_scans(office):
    _, scans, poses = office
    scans = [s[:1] for s in scans[:6]] + [np.empty((0, 2))] + list(scans[7:])
    model = ObservationGraphPartitioner(scan_matching=False).fit(scans, poses)
    covered = np.sort(np.concatenate([leaf.indices for leaf in model.split_tree_.leaves()]))
    np.testing.assert_array_equal(covered, np.delete(np.arange(len(scans)), 6))


def test_every_ordering_puts_node_0_in_a():
    rng = np.random.default_rng(3)
    for _ in range(8):  # some orderings give the eigenvector with node 0 below its mean
        order = rng.permutation(6)
        mask, y = spectral_bisection(two_cliques()[np.ix_(order, order)])
        assert mask[0] and mask.sum() == 3
        np.testing.assert_array_equal(mask, y >= y.mean())


def test_all_empty_scans_leave_an_empty_split_tree():
    model = ObservationGraphPartitioner(scan_matching=False)
    model.fit([np.empty((0, 2))] * 3, np.zeros((3, 3)))
    assert model.split_tree_.indices.tolist() == []
