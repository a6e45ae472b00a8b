"""Odometry refined by scan matching consecutive scans (``refine_poses``)."""

import numpy as np
import pytest

from common.geometry import se2_relative
from mapping.grouping import simulate_odometry
from mapping.scan_matching import densify_scan, icp_batch, refine_poses


@pytest.mark.parametrize("decimation", [1, 2])
def test_refine_poses_removes_most_odometry_drift(office, decimation):
    _, scans, poses = office
    odo = simulate_odometry(poses, np.random.default_rng(3), 0.05, 0.02)
    refined = refine_poses(scans, odo, decimation=decimation)
    np.testing.assert_array_equal(refined[0], odo[0])

    def increment_error(est):
        return np.abs(se2_relative(est[:-1], est[1:]) - se2_relative(poses[:-1], poses[1:]))

    assert np.median(increment_error(refined)) < 0.2 * np.median(increment_error(odo))
    drift = np.hypot(*(odo[:, :2] - poses[:, :2]).T).max()
    assert np.hypot(*(refined[:, :2] - poses[:, :2]).T).max() < 0.5 * drift


def test_refine_poses_decimation_matches_every_kth_source_point(office):
    _, scans, poses = office
    odo = simulate_odometry(poses[:6], np.random.default_rng(1), 0.05, 0.02)
    halved = refine_poses(scans[:6], odo, decimation=2)
    # the same as ICP of every second point onto the whole previous scan
    res = icp_batch(
        [s[::2] for s in scans[1:6]],
        [densify_scan(s) for s in scans[:5]],
        se2_relative(odo[:-1], odo[1:]),
        min_matches=10,
    )
    assert res.converged.all()
    np.testing.assert_allclose(se2_relative(halved[:-1], halved[1:]), res.transforms, atol=1e-12)
    assert not np.allclose(halved, refine_poses(scans[:6], odo))
    for bad in (0, -1, 1.5, True, "2"):
        with pytest.raises(ValueError, match="decimation must be a positive integer"):
            refine_poses(scans[:6], odo, decimation=bad)


def test_refine_poses_keeps_odometry_for_empty_scans(office):
    _, scans, poses = office
    scans = list(scans[:5])
    scans[2] = np.empty((0, 2))
    odo = simulate_odometry(poses[:5], np.random.default_rng(0), 0.05, 0.02)
    refined = refine_poses(scans, odo)
    # both increments touching the empty scan are the odometry ones
    np.testing.assert_allclose(
        se2_relative(refined[1:3], refined[2:4]), se2_relative(odo[1:3], odo[2:4]), atol=1e-12
    )
