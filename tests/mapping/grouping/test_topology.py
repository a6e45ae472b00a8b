"""Local maps and the metric-topological map."""

import numpy as np
import pytest

from common.geometry import se2_inverse, se2_relative, transform_points
from mapping.grouping import office_path, office_world, raycast, simulate_odometry
from mapping.grouping.partitioner import ObservationGraphPartitioner
from mapping.grouping.topology import (
    build_local_maps,
    build_topology,
    fill_from_nearest,
    group_frames,
)


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


POSES = np.column_stack([np.arange(8.0), np.zeros(8), np.zeros(8)])
LABELS = np.array([0, 0, 0, 1, 1, 1, 2, 2])


@pytest.mark.parametrize(
    ("poses", "labels", "match"),
    [
        (POSES, np.array([0, 0, 0, 2, 2, 2, 2, 2]), r"without gaps; no scan has label\(s\) \[1\]"),
        (POSES, LABELS[:5], r"labels must have one entry per scan \(8\), got 5"),
        (POSES, LABELS.astype(float), "labels must be a 1-D array of integer group labels"),
        (POSES, LABELS - 2, "labels must be -1 .* got -2"),
        (np.where(POSES == 3.0, np.nan, POSES), LABELS, r"poses contains NaN or inf \(rows \[3\]"),
        (POSES[:, :2], LABELS, r"poses must have shape \(N, 3\)"),
    ],
)
def test_group_frames_refuses_labels_it_cannot_use(poses, labels, match):
    """A gap crashed in argmin of an empty group; short labels and NaN poses passed silently."""
    with pytest.raises(ValueError, match=match):
        group_frames(poses, labels)


def test_build_topology_and_fill_check_their_labels():
    reference, frames = group_frames(POSES, LABELS)
    assert group_frames(POSES, list(LABELS))[0].tolist() == reference.tolist()  # a list works
    with pytest.raises(ValueError, match="labels must be a 1-D array of integer"):
        build_topology(POSES, LABELS.astype(float), np.eye(8), reference, frames)
    with pytest.raises(ValueError, match=r"labels must be groups 0..1 of the 2 frames, got 2"):
        build_topology(POSES, LABELS, np.eye(8), reference[:2], frames[:2])
    with pytest.raises(ValueError, match=r"affinity must be \(8, 8\)"):
        build_topology(POSES, LABELS, np.eye(7), reference, frames)
    # None is a missing run label, like NaN (it failed sorting against the ints)
    with pytest.raises(ValueError, match="groups contains None"):
        build_topology(POSES, LABELS, np.eye(8), reference, frames, groups=[None] * 4 + [1] * 4)
    mixed = np.array(["a"] * 6 + [1] * 2, dtype=object)  # labels numpy cannot sort
    topo = build_topology(POSES, LABELS, np.eye(8), reference, frames, groups=mixed)
    assert topo.edges() == [(0, 1)]  # the 1-2 step crosses runs
    with pytest.raises(ValueError, match=r"label\(s\) \['a', 1\] occur in separate stretches"):
        build_topology(POSES, LABELS, np.eye(8), reference, frames, groups=mixed[[0, 7] * 4])
    scans = [np.zeros((2, 2))] * 8
    with pytest.raises(ValueError, match=r"scans must have one scan per label \(8\), got 7"):
        build_local_maps(scans[:7], POSES, LABELS, frames)
    np.testing.assert_array_equal(fill_from_nearest([-1, 0, -1]), [0, 0, 0])
    with pytest.raises(ValueError, match=r"starts must be a boolean mask of shape \(6,\)"):
        fill_from_nearest(np.array([-1, 0, -1, -1, 1, -1]), np.array([True, False, True]))
    with pytest.raises(ValueError, match="labels must be a 1-D array of integer"):
        fill_from_nearest(np.array([-1.0, 0.0]))
