"""Loop closure with a GTSAM pose graph."""

import numpy as np
import pytest

from mapping.grouping import office_path, office_world, raycast, simulate_odometry
from mapping.grouping.pose_graph import absolute_trajectory_error, close_loops
from mapping.scan_matching import refine_poses


@pytest.fixture(scope="module")
def office():
    world = office_world()
    poses = office_path(world, step=0.5)
    scans = raycast(world.segments, poses, range_noise=0.005, rng=np.random.default_rng(1))
    return scans, poses


def test_loop_closure_reduces_the_drift_of_scan_matching(office):
    scans, poses = office
    odo = simulate_odometry(poses, np.random.default_rng(5), 0.1, 0.05)
    res = close_loops(scans, odo)
    np.testing.assert_allclose(
        res.chained, refine_poses(scans, odo, max_correspondence_distance=0.5), atol=1e-6
    )
    assert len(res.loops) > 0 and res.candidates >= len(res.loops)
    assert res.error_after < res.error_before
    before = absolute_trajectory_error(res.chained, poses)["rmse_m"]
    after = absolute_trajectory_error(res.poses, poses)["rmse_m"]
    assert after < 0.95 * before  # the office's room tours are small loops
    np.testing.assert_allclose(res.poses[0], odo[0], atol=1e-3)  # the prior anchors the start


def test_absolute_trajectory_error_of_a_shift():
    truth = np.zeros((4, 3))
    est = truth + [3.0, 4.0, 0.0]
    ate = absolute_trajectory_error(est, truth)
    assert ate["rmse_m"] == pytest.approx(5.0) and ate["max_m"] == pytest.approx(5.0)


@pytest.mark.parametrize(
    ("kwargs", "match"),
    [({"robust": "l1"}, "robust"), ({"odometry": np.full((2, 3), np.nan)}, "NaN")],
)
def test_close_loops_refuses_bad_input(kwargs, match):
    scans = [np.zeros((0, 2))] * 2
    args = {"odometry": np.zeros((2, 3)), **kwargs}
    with pytest.raises(ValueError, match=match):
        close_loops(scans, **args)
