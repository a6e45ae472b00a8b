"""Incremental grouping (``partial_fit``) against the batch ``fit``."""

import numpy as np
import pytest
from sklearn.base import clone

from mapping.grouping import office_path, office_world, raycast
from mapping.grouping.incremental_overlap import VoxelOverlapIndex
from mapping.grouping.partitioner import ObservationGraphPartitioner
from mapping.metrics import adjusted_rand_index, purity


@pytest.fixture(scope="module")
def office():
    world = office_world()
    poses = office_path(world, step=1.17)
    return world, raycast(world.segments, poses), poses


def scan_by_scan(model, scans, poses, chunk=1):
    for i in range(0, len(scans), chunk):
        model.partial_fit(scans[i : i + chunk], poses[i : i + chunk])
    return model


def test_graph_is_the_batch_graph(office):
    _, scans, poses = office
    batch = ObservationGraphPartitioner(scan_matching=False).fit(scans, poses)
    inc = scan_by_scan(ObservationGraphPartitioner(scan_matching=False), scans, poses, chunk=5)
    assert abs(inc.affinity_matrix_ - batch.affinity_matrix_).max() == 0.0
    np.testing.assert_array_equal(inc.poses_, poses)
    # a local re-partition per scan: close to the batch groups, and as pure
    world = office[0]
    truth = world.region_labels(poses)
    assert purity(truth, inc.labels_) >= 0.9
    assert adjusted_rand_index(batch.labels_, inc.labels_) > 0.7
    assert inc.n_groups_ == inc.labels_.max() + 1 == len(inc.local_maps_)
    assert inc.topology_.n_nodes == inc.n_groups_ and not hasattr(inc, "split_tree_")


def test_separate_places_agree_with_batch(office):
    """A second building far away shares no arc with the first: re-partitioning what the new
    scans touch is then exactly what the batch recursion does to each component."""
    _, scans, poses = office
    far = poses + [1000.0, 0.0, 0.0]
    both_scans, both_poses = list(scans) + list(scans), np.concatenate([poses, far])
    batch = ObservationGraphPartitioner(scan_matching=False).fit(both_scans, both_poses)
    model = ObservationGraphPartitioner(scan_matching=False)
    model.partial_fit(scans, poses)
    first = model.labels_.copy()
    model.partial_fit(scans, far)
    np.testing.assert_array_equal(model.labels_[: len(scans)], first)  # untouched groups
    n = len(scans)
    # the second building is grouped exactly like the first, shifted by its group count
    np.testing.assert_array_equal(model.labels_[n:], first + first.max() + 1)
    assert abs(model.affinity_matrix_ - batch.affinity_matrix_).max() == 0.0


def test_scan_matching_chains_across_calls(office):
    _, scans, poses = office
    odo = poses.copy()
    odo[:, :2] += np.linspace(0, 1, len(poses))[:, None]  # drift the odometry
    batch = ObservationGraphPartitioner().fit(scans, odo)
    inc = scan_by_scan(ObservationGraphPartitioner(), scans, odo, chunk=7)
    np.testing.assert_allclose(inc.poses_, batch.poses_, atol=1e-9)


def test_empty_scans_and_errors(office):
    _, scans, poses = office
    scans = list(scans[:20])
    scans[5] = np.empty((0, 2))
    inc = scan_by_scan(ObservationGraphPartitioner(scan_matching=False), scans, poses[:20])
    assert inc.labels_[5] in (inc.labels_[4], inc.labels_[6])
    noise = ObservationGraphPartitioner(scan_matching=False, empty_scans="noise")
    assert scan_by_scan(noise, scans, poses[:20]).labels_[5] == -1
    fitted = ObservationGraphPartitioner(scan_matching=False).fit(scans, poses[:20])
    with pytest.raises(ValueError, match="continues only a partial_fit sequence"):
        fitted.partial_fit(scans[:1], poses[:1])
    clone(fitted).partial_fit(scans[:1], poses[:1])  # a clone starts a new sequence
    with pytest.raises(ValueError, match="needs affinity='sso' and a voxel_size"):
        ObservationGraphPartitioner(voxel_size=None).partial_fit(scans[:1], poses[:1])
    with pytest.raises(ValueError, match="same length"):
        ObservationGraphPartitioner().partial_fit(scans[:2], poses[:1])
    # fit() after partial_fit starts over
    refit = scan_by_scan(ObservationGraphPartitioner(scan_matching=False), scans, poses[:20])
    refit.fit(scans, poses[:20])
    np.testing.assert_array_equal(refit.labels_, fitted.labels_)


def test_where_every_scan_touches_every_group_it_is_the_batch_partition():
    """Scans that all overlap each other (one room, turning about): every new scan touches
    every group, so each update re-partitions the whole graph, as ``fit`` does. (A threshold
    of 1.5 splits such a clique at all; at 1 it stays one group.)"""
    world = office_world()
    yaw = np.linspace(0, 4 * np.pi, 40)
    poses = np.column_stack([np.full(40, 3.0), np.full(40, 4.5), yaw])
    scans = raycast(world.segments, poses, n_beams=90)
    batch = ObservationGraphPartitioner(threshold=1.5, scan_matching=False).fit(scans, poses)
    assert batch.affinity_matrix_.nnz == 40 * 40  # every scan overlaps every other
    inc = scan_by_scan(
        ObservationGraphPartitioner(threshold=1.5, scan_matching=False), scans, poses
    )
    np.testing.assert_array_equal(inc.labels_, batch.labels_)
    assert batch.n_groups_ > 1  # and the graph is really partitioned


def test_a_near_scan_sharing_no_voxel_is_added():
    """The robot turned round: the second scan is within the search radius of the first but
    sees the opposite wall, so no voxel is shared (bincount of no hit gave int64 and the
    division crashed)."""
    wall_ahead = np.column_stack([np.full(20, 2.0), np.linspace(-1, 1, 20)])
    model = ObservationGraphPartitioner(scan_matching=False)
    model.partial_fit([wall_ahead], np.array([[0.0, 0.0, 0.0]]))
    model.partial_fit([wall_ahead], np.array([[0.0, 0.0, np.pi]]))
    np.testing.assert_array_equal(model.labels_, [0, 1])
    assert model.affinity_matrix_[0, 1] == 0.0
    index = VoxelOverlapIndex(0.2, 0.05)
    index.add(wall_ahead, np.zeros(3))
    idx, w = index.add(wall_ahead, np.array([0.0, 0.0, np.pi]))
    assert idx.size == 0 and w.dtype == np.float64


@pytest.mark.parametrize(
    ("delta", "voxel_size", "match"),
    [
        (0.2, 0.0, r"voxel_size must be a number in \(0, delta"),
        (0.2, -0.05, "voxel_size must be"),
        (-0.2, 0.05, "delta must be a positive finite number"),
        (np.nan, 0.05, "delta must be"),
        (0.2, None, "voxel_size must be a number"),
        (0.2, 0.3, "voxel_size must be"),
    ],
)
def test_voxel_overlap_index_refuses_bad_sizes(delta, voxel_size, match):
    with pytest.raises(ValueError, match=match):
        VoxelOverlapIndex(delta, voxel_size)


@pytest.mark.parametrize(
    ("points", "pose", "match"),
    [
        (np.ones((5, 3)), np.zeros(3), r"points must have shape \(M, 2\)"),
        (np.array([[np.nan, 1.0]]), np.zeros(3), "points contains NaN or inf"),
        (np.array([[np.inf, 1.0]]), np.zeros(3), "points contains NaN or inf"),
        (np.ones((5, 2)), np.zeros(2), r"pose must have shape \(3,\)"),
        (np.ones((5, 2)), np.array([0.0, np.nan, 0.0]), "pose contains NaN"),
        (np.ones((5, 2)), np.array([1e9, 0.0, 0.0]), "points: voxel coordinates beyond"),
    ],
)
def test_voxel_overlap_index_refuses_bad_scans(points, pose, match):
    index = VoxelOverlapIndex(0.2, 0.05)
    with pytest.raises(ValueError, match=match):
        index.add(points, pose)
    assert len(index) == 0  # nothing half-added


def test_partial_fit_rebuilds_what_it_read_and_keeps_no_tree(office):
    _, scans, poses = office
    model = ObservationGraphPartitioner(scan_matching=False)
    model.partial_fit(scans[:6], poses[:6])
    first = (model.n_groups_, len(model.local_maps_), model.topology_.frames.shape[0])
    assert first == (model.n_groups_,) * 3
    more = [*scans[6:], np.empty((0, 2))]  # the last scan saw nothing: still a node
    model.partial_fit(more, np.concatenate([poses[6:], poses[-1:]]))
    n = len(scans) + 1
    assert model.affinity_matrix_.shape == (n, n) and model.n_groups_ > first[0]
    assert len(model.local_maps_) == model.topology_.frames.shape[0] == model.n_groups_
    assert not hasattr(model, "split_tree_")
    with pytest.raises(
        AttributeError, match="^'ObservationGraphPartitioner' object has no attribute 'nothing_'$"
    ):
        _ = model.nothing_


def test_partial_fit_topology_nodes_are_its_groups(office):
    _, scans, poses = office
    inc = ObservationGraphPartitioner(scan_matching=False).partial_fit(scans, poses)
    ref = inc.topology_.reference_scans
    np.testing.assert_array_equal(inc.labels_[ref], np.arange(inc.n_groups_))


def test_partial_fit_needs_the_scans_overlap():
    model = ObservationGraphPartitioner(affinity="precomputed")
    with pytest.raises(
        ValueError,
        match=r"^partial_fit needs affinity='sso' and a voxel_size "
        r"\(not None\)$",
    ):
        model.partial_fit([np.ones((3, 2))], np.zeros((1, 3)))
    with pytest.raises(ValueError, match=r"^X must be the scans, .* \(affinity='sso'\), got None$"):
        ObservationGraphPartitioner().partial_fit(None, np.zeros((1, 3)))


def test_auto_voxel_is_a_quarter_of_the_match_distance(office):
    _, scans, poses = office
    auto = ObservationGraphPartitioner(scan_matching=False, match_distance=0.2).fit(scans, poses)
    given = ObservationGraphPartitioner(scan_matching=False, match_distance=0.2, voxel_size=0.05)
    np.testing.assert_array_equal(
        auto.affinity_matrix_.toarray(), given.fit(scans, poses).affinity_matrix_.toarray()
    )


def test_partial_fit_rebuilds_the_topology_read_first(office):
    _, scans, poses = office
    model = ObservationGraphPartitioner(scan_matching=False).partial_fit(scans[:6], poses[:6])
    assert model.topology_.frames.shape[0] == model.n_groups_
    model.partial_fit(scans[6:], poses[6:])
    assert model.topology_.frames.shape[0] == model.n_groups_
