"""SE(2) algebra, angle wrapping and scan geometry."""

import numpy as np
import pytest

from common.geometry import (
    circular_mean,
    scan_to_points,
    se2_compose,
    se2_inverse,
    se2_mean,
    se2_relative,
    transform_points,
    wrap_angle,
)


def test_se2_algebra():
    rng = np.random.default_rng(0)
    a = rng.uniform(-3, 3, (10, 3))
    b = rng.uniform(-3, 3, (10, 3))
    np.testing.assert_allclose(se2_compose(a, se2_inverse(a)), np.zeros((10, 3)), atol=1e-12)
    np.testing.assert_allclose(se2_compose(a, se2_relative(a, b))[:, :2], b[:, :2], atol=1e-12)
    # composing poses is composing point maps
    p = rng.normal(size=(5, 2))
    np.testing.assert_allclose(
        transform_points(se2_compose(a[0], b[0]), p),
        transform_points(a[0], transform_points(b[0], p)),
        atol=1e-12,
    )
    np.testing.assert_allclose(
        transform_points([0, 0, np.pi / 2], [[1.0, 0.0]]), [[0, 1.0]], atol=1e-15
    )


def test_circular_mean_across_pi():
    assert abs(abs(circular_mean([np.pi - 0.1, -np.pi + 0.1])) - np.pi) < 1e-12
    assert circular_mean([0.1, -0.1, 0.3]) == pytest.approx(0.1, abs=1e-3)


def test_wrap_angle_range_and_periodicity():
    theta = np.linspace(-20, 20, 401)
    w = wrap_angle(theta)
    assert ((w >= -np.pi) & (w < np.pi)).all()
    np.testing.assert_allclose(np.cos(w), np.cos(theta), atol=1e-12)
    np.testing.assert_allclose(np.sin(w), np.sin(theta), atol=1e-12)
    assert wrap_angle(np.pi) == pytest.approx(-np.pi)


def test_se2_mean_averages_headings_across_pi():
    poses = [[0.0, 0.0, np.pi - 0.1], [2.0, 4.0, -np.pi + 0.1]]
    mean = se2_mean(poses)
    np.testing.assert_allclose(mean[:2], [1.0, 2.0])
    assert abs(abs(mean[2]) - np.pi) < 1e-12


def test_scan_to_points_sensor_frame_and_drops_no_returns():
    angles = np.array([0.0, np.pi / 2, np.pi, -np.pi / 2, 0.3])
    ranges = np.array([2.0, 1.0, np.inf, 3.0, np.nan], dtype=np.float32)
    pts = scan_to_points(ranges, angles)
    np.testing.assert_allclose(pts, [[2.0, 0.0], [0.0, 1.0], [0.0, -3.0]], atol=1e-12)
    assert scan_to_points(ranges, angles, max_range=3.0).shape == (2, 2)
    with pytest.raises(ValueError, match="same length"):
        scan_to_points(ranges, angles[:3])
    # a beam with a NaN angle has no direction: dropped like a missing return
    assert scan_to_points([1.0, 2.0], [0.0, np.nan]).shape == (1, 2)


def test_thin_to_grid_keeps_one_point_per_cell():
    from common.geometry import thin_to_grid

    pts = np.array([[0.01, 0.01], [0.04, 0.02], [0.12, 0.01], [-0.01, 0.0]])
    out = thin_to_grid(pts, 0.05)
    np.testing.assert_allclose(out, [[-0.025, 0.025], [0.025, 0.025], [0.125, 0.025]])
