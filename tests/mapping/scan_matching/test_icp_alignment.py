"""Point-to-point ICP in SE(2): one pair, a batch, and the densified target."""

import numpy as np
import pytest

from common.geometry import se2_relative, transform_points
from mapping.scan_matching.icp_alignment import _kabsch_2d, densify_scan, icp, icp_batch


@pytest.mark.parametrize("yaw", [0.3, -3.0, np.pi - 1e-3])
def test_kabsch_is_exact_on_noise_free_points(yaw):
    rng = np.random.default_rng(0)
    p = rng.normal(size=(30, 2))
    T = np.array([0.7, -1.2, yaw])
    np.testing.assert_allclose(_kabsch_2d(p, transform_points(T, p)), T, atol=1e-12)


def test_icp_recovers_a_known_transform(office):
    _, scans, poses = office
    # a scan inside a room sees corners in both directions (a corridor scan could slide)
    target = scans[int(np.flatnonzero(poses[:, 1] > 4.0)[0])]
    true = np.array([0.25, -0.15, 0.08])
    # source: the target's points seen from a frame displaced by `true`
    source = transform_points(se2_relative(true, np.zeros(3)), target)
    res = icp(source, target)
    assert res.converged
    np.testing.assert_allclose(res.transform, true, atol=1e-6)
    assert res.rmse < 1e-6 and res.n_matches == len(source)


def test_icp_with_odometry_seed_on_consecutive_scans(office):
    _, scans, poses = office
    errors = []
    for i in range(1, len(poses), 7):
        true = se2_relative(poses[i - 1], poses[i])
        seed = true + np.array([0.1, -0.05, 0.04])
        res = icp(scans[i], densify_scan(scans[i - 1]), init=seed)
        errors.append(np.abs(res.transform - true))
    errors = np.array(errors)
    # the seed is 10 cm / 0.04 rad off; ICP brings the median error well under that
    assert np.median(errors[:, :2]) < 0.02 and np.median(errors[:, 2]) < 0.01


def test_icp_gives_up_without_points():
    res = icp(np.zeros((3, 2)), np.ones((50, 2)), init=[1.0, 2.0, 0.5])
    assert not res.converged and res.n_matches == 0
    np.testing.assert_array_equal(res.transform, [1.0, 2.0, 0.5])
    with pytest.raises(ValueError, match="max_correspondence_distance must be positive"):
        icp(np.ones((20, 2)), np.ones((20, 2)), max_correspondence_distance=0.0)


def test_densify_scan_fills_small_gaps_only():
    pts = np.array([[0.0, 0.0], [0.1, 0.0], [2.0, 0.0]])
    dense = densify_scan(pts, spacing=0.02, max_gap=0.3)
    assert np.all(np.diff(dense[dense[:, 0] <= 0.1, 0]) <= 0.02 + 1e-12)
    # the 1.9 m jump stays a jump
    assert not np.any((dense[:, 0] > 0.1) & (dense[:, 0] < 2.0))


def _brute_force_icp(source, target, init, max_d=0.5, min_d=0.05, iters=50, tol=1e-6, min_m=10):
    """The ICP of ``icp``'s docstring with nearest neighbours from all pairwise distances: the
    reference for the batch's remembered-neighbour shortcut."""
    x, y, yaw = init
    for _ in range(iters):
        c, s = np.cos(yaw), np.sin(yaw)
        moved = source @ np.array([[c, s], [-s, c]]) + (x, y)
        dist = np.linalg.norm(moved[:, None] - target[None], axis=2)
        idx, d = dist.argmin(axis=1), dist.min(axis=1)
        ok = d <= max_d
        if ok.sum() < min_m:
            return np.array([x, y, yaw]), False
        ok &= d <= max(3 * np.median(d[ok]), min_d)
        sx, sy, syaw = _kabsch_2d(moved[ok], target[idx[ok]])
        cs, ss = np.cos(syaw), np.sin(syaw)
        x, y, yaw = sx + cs * x - ss * y, sy + ss * x + cs * y, yaw + syaw
        if np.hypot(sx, sy) < tol and abs(syaw) < tol:
            return np.array([x, y, np.angle(np.exp(1j * yaw))]), True
    return np.array([x, y, np.angle(np.exp(1j * yaw))]), False


def test_icp_batch_matches_exact_nearest_neighbour_icp(office):
    _, scans, poses = office
    rng = np.random.default_rng(5)
    idx = np.arange(1, len(scans), 3)
    sources = [scans[i] for i in idx]
    targets = [densify_scan(scans[i - 1], spacing=0.05) for i in idx]
    noise = rng.normal(0, [0.08, 0.08, 0.04], (len(idx), 3))
    inits = se2_relative(poses[idx - 1], poses[idx]) + noise
    batch = icp_batch(sources, targets, inits)
    for k, (src, tgt, init) in enumerate(zip(sources, targets, inits, strict=True)):
        ref, converged = _brute_force_icp(src, tgt, init)
        assert batch.converged[k] == converged
        np.testing.assert_allclose(batch.transforms[k], ref, atol=1e-9)
        # a pair's result does not depend on the other pairs in the batch
        single = icp(src, tgt, init)
        np.testing.assert_allclose(single.transform, batch.transforms[k], atol=1e-9)
        assert single.n_iterations == batch.n_iterations[k]


def test_icp_batch_leaves_short_pairs_at_their_seed_and_checks_shapes():
    pts = np.random.default_rng(0).uniform(-3, 3, (40, 2))
    res = icp_batch([pts, pts[:4], np.empty((0, 2))], [pts, pts, pts], np.zeros((3, 3)))
    assert res.converged.tolist() == [True, False, False]
    np.testing.assert_array_equal(res.transforms[1:], 0.0)
    assert res[1].n_matches == 0 and res[2].n_iterations == 0
    with pytest.raises(ValueError, match="inits must have shape"):
        icp_batch([pts], [pts], np.zeros(3))
    with pytest.raises(ValueError, match="one entry per source"):
        icp_batch([pts, pts], [pts], np.zeros((2, 3)))
    with pytest.raises(ValueError, match="target_tree is only for a single pair"):
        from scipy.spatial import cKDTree

        icp_batch([pts, pts], [pts, pts], np.zeros((2, 3)), target_tree=cKDTree(pts))
