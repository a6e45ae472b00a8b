"""Local maps and the metric-topological map."""

import numpy as np
import pytest

from common.geometry import se2_inverse, se2_relative, transform_points
from mapping._synthetic_scans import office_path, office_world, raycast, simulate_odometry
from mapping.partition import ObservationGraphPartitioner
from mapping.topology import build_topology


@pytest.fixture(scope="module")
def office():
    world = office_world()
    poses = office_path(world, step=0.6)
    return world, raycast(world.segments, poses), poses


def test_arcs_follow_the_trajectory(office):
    _, scans, poses = office
    model = ObservationGraphPartitioner(scan_matching=False).fit(scans, poses)
    topo = model.topology_
    edges = set(topo.edges())
    labels = model.labels_
    for i in np.flatnonzero(labels[1:] != labels[:-1]):
        a, b = sorted((labels[i], labels[i + 1]))
        assert (a, b) in edges
    assert topo.n_nodes == model.n_groups_
    assert all(arc.source < arc.target and arc.n_pairs > 0 for arc in topo.arcs)
    # one global pose estimate: every pair gives the same estimate
    assert max(arc.spread.max() for arc in topo.arcs) < 1e-9


def test_local_maps_are_in_the_reference_frame(office):
    _, scans, poses = office
    model = ObservationGraphPartitioner(scan_matching=False).fit(scans, poses)
    for k, ref in enumerate(model.topology_.reference_scans):
        assert model.labels_[ref] == k
        members = np.flatnonzero(model.labels_ == k)
        assert len(model.local_maps_[k]) == sum(len(scans[i]) for i in members)
        # in its own frame the world points of the group are the local map
        world = transform_points(model.topology_.frames[k], model.local_maps_[k])
        expected = np.concatenate([transform_points(poses[i], scans[i]) for i in members])
        np.testing.assert_allclose(world, expected, atol=1e-9)


@pytest.mark.parametrize("scan_matching", [False, True])
def test_relative_transforms_match_the_truth(office, scan_matching):
    _, scans, poses = office
    odo = simulate_odometry(poses, np.random.default_rng(5), 0.01, 0.002)
    model = ObservationGraphPartitioner(scan_matching=scan_matching).fit(scans, odo)
    topo = model.topology_
    assert topo.arcs
    for arc in topo.arcs:
        ra, rb = topo.reference_scans[arc.source], topo.reference_scans[arc.target]
        true = se2_relative(poses[ra], poses[rb])
        err = se2_relative(true, arc.transform)
        # the odometry error accumulated between the two reference scans bounds the error
        path = np.hypot(*np.diff(poses[min(ra, rb) : max(ra, rb) + 1, :2], axis=0).T).sum()
        assert np.hypot(err[0], err[1]) < 0.05 + 0.01 * path * 3
        assert abs(err[2]) < 0.01 + 0.002 * abs(rb - ra) ** 0.5 * 4
    a, b = topo.arcs[0].source, topo.arcs[0].target
    np.testing.assert_allclose(topo.transform(b, a), se2_inverse(topo.transform(a, b)))
    with pytest.raises(KeyError, match="no arc"):
        topo.transform(0, 10_000)


def test_no_trajectory_arc_across_runs():
    poses = np.array([[0.0, 0, 0], [1, 0, 0], [10, 0, 0], [11, 0, 0]])
    labels = np.array([0, 0, 1, 1])
    W = np.eye(4)  # no overlap between the groups
    frames = poses[[0, 2]]
    assert build_topology(poses, labels, W, np.array([0, 2]), frames).edges() == [(0, 1)]
    runs = [0, 0, 1, 1]
    assert build_topology(poses, labels, W, np.array([0, 2]), frames, groups=runs).arcs == []
