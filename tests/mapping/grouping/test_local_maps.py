"""Local maps rebuilt from groups, their consistency, held-out localisation, submap baselines."""

import numpy as np
import pytest

from common.geometry import transform_points
from mapping.grouping import office_path, office_world, raycast, simulate_odometry
from mapping.grouping.local_maps import (
    align_groups,
    localise_held_out,
    map_residuals,
    submap_labels,
)


@pytest.fixture(scope="module")
def office():
    world = office_world()
    poses = office_path(world, step=0.5)[:60]
    scans = raycast(world.segments, poses, range_noise=0.005, rng=np.random.default_rng(1))
    return scans, poses


def test_submap_labels_by_count_and_by_distance():
    poses = np.column_stack([np.arange(10.0), np.zeros(10), np.zeros(10)])
    np.testing.assert_array_equal(submap_labels(poses, n_scans=4), [0] * 4 + [1] * 4 + [2] * 2)
    np.testing.assert_array_equal(submap_labels(poses, distance=3.0), [0] * 4 + [1] * 4 + [2] * 2)
    runs = np.array([0] * 5 + [1] * 5)
    np.testing.assert_array_equal(
        submap_labels(poses, n_scans=4, groups=runs), [0] * 4 + [1] + [2] * 4 + [3]
    )


@pytest.mark.parametrize(
    ("kwargs", "match"),
    [({}, "exactly one"), ({"n_scans": 0}, "n_scans"), ({"distance": -1.0}, "distance")],
)
def test_submap_labels_refuses_bad_sizes(kwargs, match):
    with pytest.raises(ValueError, match=match):
        submap_labels(np.zeros((3, 3)), **kwargs)


def test_true_poses_give_crisp_maps_and_drift_does_not(office):
    scans, poses = office
    labels = submap_labels(poses, n_scans=10)
    crisp = map_residuals(scans, poses, labels)
    odo = simulate_odometry(poses, np.random.default_rng(3), 0.05, 0.03)
    smeared = map_residuals(scans, odo, labels)
    assert crisp["mean_m"] < 0.05 and crisp["pairs"] > 0
    assert smeared["mean_m"] > 2 * crisp["mean_m"]


def test_align_groups_makes_drifted_submaps_crisp_again(office):
    scans, poses = office
    labels = submap_labels(poses, n_scans=10)
    odo = simulate_odometry(poses, np.random.default_rng(3), 0.05, 0.03)
    aligned = align_groups(scans, odo, labels)
    before = map_residuals(scans, odo, labels)["mean_m"]
    after = map_residuals(scans, aligned, labels)["mean_m"]
    assert after < 0.6 * before
    first = [np.flatnonzero(labels == g)[0] for g in np.unique(labels)]
    np.testing.assert_array_equal(aligned[first], odo[first])  # each map keeps its anchor


def test_held_out_scans_localise_against_a_consistent_map(office):
    scans, poses = office
    held = np.array([12, 27, 44])
    train = np.setdiff1d(np.arange(len(poses)), held)
    cloud = np.concatenate([transform_points(poses[k], scans[k]) for k in train])
    rng = np.random.default_rng(0)
    errors = localise_held_out(
        scans, poses, poses, held, held - 1, {0: cloud}, [0] * 3, rng, init_sigma=(0.05, 0.01)
    )
    assert np.all(errors[:, 0] < 0.1) and np.all(errors[:, 1] < np.deg2rad(2))
    # walls 15 cm thick: the points of both faces are within the 0.5 m gate
    # a map shifted across the corridor relative to the anchor's pose: the error shows it
    shifted = {0: cloud + [0.0, 0.3]}
    errors = localise_held_out(
        scans, poses, poses, held, held - 1, shifted, [0] * 3, rng, init_sigma=(0.05, 0.01)
    )
    assert errors[:, 0].mean() > 0.15  # a scan along a corridor cannot see part of the shift


def test_submap_labels_refuses_nan_poses_and_bool_counts():
    poses = np.column_stack([np.arange(10.0), np.zeros(10), np.zeros(10)])
    poses[2, 0] = np.nan  # every later scan fell into one submap
    with pytest.raises(ValueError, match=r"poses contains NaN or inf \(rows \[2\]\)"):
        submap_labels(poses, distance=1.0)
    with pytest.raises(ValueError, match="n_scans must be an integer >= 1, got True"):
        submap_labels(np.zeros((3, 3)), n_scans=True)
    with pytest.raises(ValueError, match="distance must be a positive number"):
        submap_labels(np.zeros((3, 3)), distance="3")


def test_maps_refuse_labels_and_poses_that_do_not_fit_the_scans(office):
    scans, poses = office
    labels = np.zeros(len(scans), dtype=int)
    for f in (map_residuals, align_groups):
        with pytest.raises(ValueError, match=rf"labels must have shape \({len(scans)},\)"):
            f(scans, poses, [0, 0])
        with pytest.raises(ValueError, match="labels must be integer group ids"):
            f(scans, poses, np.full(len(scans), np.nan))
        nan_pose = poses.copy()
        nan_pose[2, 0] = np.nan
        with pytest.raises(ValueError, match=r"poses contains NaN or inf \(rows \[2\]\)"):
            f(scans, nan_pose, labels)
        with pytest.raises(ValueError, match="poses and scans must have the same length"):
            f(scans, poses[:-1], labels)


def test_localise_held_out_refuses_bad_indices(office):
    scans, poses = office
    rng = np.random.default_rng(0)
    cloud = {0: np.concatenate([transform_points(poses[k], scans[k]) for k in range(5)])}
    with pytest.raises(ValueError, match=r"held_out must index the 60 scans"):
        localise_held_out(scans, poses, poses, [60], [1], cloud, [0], rng)
    with pytest.raises(ValueError, match="one entry per held-out scan"):
        localise_held_out(scans, poses, poses, [3, 4], [2], cloud, [0, 0], rng)
    with pytest.raises(ValueError, match=r"truth must be finite poses of shape \(60, 3\)"):
        localise_held_out(scans, poses, poses[:-1], [3], [2], cloud, [0], rng)
