"""The map's views in one frame (pose graph over sensed edges), its point map, distance field
and sensed free space; global localisation and tracking on it."""

import numpy as np
import pytest

from common.geometry import se2_compose, se2_relative, transform_points
from servo.laser_image.laser_localise import GlobalLocaliser, ScanTracker
from servo.laser_image.metric_map import MetricMap
from servo.localise import ImageLocaliser


@pytest.fixture(scope="module")
def metric_maps(servo_maps):
    return {w: MetricMap(m) for w, m in servo_maps.items()}


def _in_world(m, pose):
    """A map-frame pose in the world frame (view 0's true pose anchors the map frame)."""
    return se2_compose(m.true_poses[0], pose)


def test_views_in_one_frame_agree_with_the_truth(servo_maps, metric_maps):
    for w, m in servo_maps.items():
        placed = _in_world(m, metric_maps[w].poses)
        err = np.hypot(*(placed[:, :2] - m.true_poses[:, :2]).T)
        assert np.median(err) < 0.15 and err.max() < 0.5, (w, np.median(err), err.max())


def test_free_space_holds_the_recorded_paths_and_no_wall(servo_maps, metric_maps, worlds):
    for w, m in servo_maps.items():
        mm = metric_maps[w]
        assert mm.grid.is_free(mm.poses[:, :2]).mean() > 0.9
        # sensed free cells lie in the world's free space (in the world frame)
        centers = mm.grid.cell_centers()[mm.grid.free]
        world_xy = transform_points(m.true_poses[0], centers)
        truth = worlds[w].free_space(0.05)
        assert truth.is_free(world_xy).mean() > 0.98


def test_distance_field_is_zero_on_the_points_and_grows_off_them(metric_maps):
    mm = metric_maps["hallway"]
    assert mm.distance(mm.points).max() <= 0.05
    far = mm.points.min(axis=0) - 50.0
    assert mm.distance(far[None])[0] == 10.0


def test_global_localisation_from_a_stored_view_all_round(servo_maps, metric_maps):
    """Two stored views' scans back to back make an all-round scan; it is placed where the
    views were, and the images of the views pick the right one among look-alikes."""
    m = servo_maps["lawn"]
    mm = metric_maps["lawn"]
    loc = GlobalLocaliser(mm, ImageLocaliser(m))
    hits = 0
    for view in range(10, len(m), 37):
        cloud = mm.points[np.hypot(*(mm.points - mm.poses[view, :2]).T) < 8.0]
        cloud = transform_points(se2_relative(mm.poses[view], np.zeros(3)), cloud)
        fix = loc.localise(cloud, [(m.features[view], 0.0)])
        hits += np.hypot(*(fix.pose[:2] - mm.poses[view, :2])) < 0.3
    assert hits >= 4


def test_tracker_corrects_a_small_error_and_refuses_a_large_one(servo_maps, metric_maps):
    m, mm = servo_maps["hallway"], metric_maps["hallway"]
    tracker = ScanTracker(mm)
    view = 40
    pts = m.scan_points(view)[::4]
    start = se2_compose(mm.poses[view], [0.1, -0.2, 0.08])
    _, fit, ok = tracker.correct(pts, start)
    before = mm.fit(pts, start, 0.1)[0]
    assert ok and fit > 0.85 and fit > before + 0.3, (fit, before)
    _, fit, ok = tracker.correct(pts, se2_compose(mm.poses[view], [0.0, 0.0, 2.5]))
    assert not ok and fit < 0.5


def test_coarse_scores_agree_with_the_distance_field(metric_maps):
    """The coarse search's cell lookups score a scan as the distance field does (offsets
    rounded to whole cells: within a few points of the exact share)."""
    from servo.laser_image.laser_localise import COARSE_TOL, CoarseField

    mm = metric_maps["hallway"]
    rng = np.random.default_rng(0)
    positions = mm.poses[::20, :2] + rng.normal(0.0, 0.2, (len(mm.poses[::20]), 2))
    pts = rng.uniform(-6.0, 6.0, (60, 2))
    yaws = np.array([-2.0, 0.0, 0.7])
    scores = CoarseField(mm, positions, reach=9.0).scores(pts, yaws)
    for k, yaw in enumerate(yaws):
        poses = np.c_[positions, np.full(len(positions), yaw)]
        c, s = np.cos(poses[:, 2]), np.sin(poses[:, 2])
        x = poses[:, None, 0] + c[:, None] * pts[None, :, 0] - s[:, None] * pts[None, :, 1]
        y = poses[:, None, 1] + s[:, None] * pts[None, :, 0] + c[:, None] * pts[None, :, 1]
        exact = (mm.distance(np.stack([x, y], -1)) <= COARSE_TOL).mean(axis=1)
        assert np.abs(scores[k] - exact).max() <= 0.1, np.abs(scores[k] - exact).max()


def test_candidate_positions_reach_past_the_sensed_free_space(metric_maps):
    from servo.laser_image.laser_localise import CANDIDATE_CLEARANCE, candidate_positions

    mm = metric_maps["hallway"]
    pos = candidate_positions(mm)
    assert mm.distance(pos).min() > CANDIDATE_CLEARANCE
    seen = mm.grid.is_free(pos)
    assert seen.mean() > 0.3 and (~seen).sum() > 0  # the free space and a margin beyond it


def test_image_distances_of_many_poses_equal_one_at_a_time(servo_maps, metric_maps):
    m, mm = servo_maps["hallway"], metric_maps["hallway"]
    loc = GlobalLocaliser(mm, ImageLocaliser(m))
    views = [(m.features[30], 0.0), (m.features[31], 1.5), (m.features[100], -2.0)]
    poses = mm.poses[[30, 80, 150, 200]] + [0.3, -0.2, 0.1]
    many = loc.image_distances(poses, views)
    one = np.array([loc.image_distances(p[None], views)[0] for p in poses])
    np.testing.assert_allclose(many, one)
    # a view's own image, from its own pose, matches it exactly
    assert loc.image_distances(mm.poses[30][None], views[:1])[0] < 1e-4
