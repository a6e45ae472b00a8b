"""``ViewPose``: the robot's metric pose against a stored view, and the belief's pose fix."""

from dataclasses import replace

import numpy as np
import pytest

from common.geometry import se2_compose
from scenes.robot import CAMERA_HEIGHT
from servo.camera_only.controller import SignalServo, SignalServoConfig
from servo.camera_only.route_belief import RouteBelief
from servo.camera_only.view_pose import PoseAgreement, ViewPose
from servo.maps.types import MapError
from servo.route import RoutePath
from servo.task.env import ServoEnv

L_FRAMES = np.array([[float(i), 0.0, 0.0] for i in range(6)])


def _rendered(env, m, view, along, left, yaw):
    """The camera image with the robot at (along, left, yaw) in stored view ``view``'s true
    frame (truth is the test's, not the estimator's)."""
    pose = se2_compose(m.true_poses[view], [along, left, yaw])
    env.base.sim.reset(pose, np.random.default_rng(0))
    return env.base.sim.render()


def test_a_view_against_its_own_image_is_at_the_view(servo_maps):
    vp = ViewPose(servo_maps["hallway"])
    rel = vp.relative(servo_maps["hallway"].images[10], 10)
    assert rel is not None and rel.inliers >= vp.min_inliers
    np.testing.assert_allclose(rel.pose, 0.0, atol=0.01)


def test_depth_points_take_the_floor_or_the_scanned_wall():
    """Below the horizon the nearer of the floor and the scanned wall; above it the wall, or
    nothing with ``upper=False``."""

    class _Map:  # the fields depth_points reads
        images = np.zeros((1, 240, 320, 3), np.uint8)
        angles = np.linspace(-np.pi / 2, np.pi / 2, 181)
        scans = np.full((1, 181), 3.0)  # a wall 3 m round the laser
        max_range = 20.0

    vp = ViewPose.__new__(ViewPose)
    vp.map = _Map()
    f = 120.0 / np.tan(np.deg2rad(22.5))
    vp.K = np.array([[f, 0.0, 160.0], [0.0, f, 120.0], [0.0, 0.0, 1.0]])
    uv = np.array([[160.0, 60.0], [160.0, 230.0], [160.0, 125.0]])
    P = vp.depth_points(0, uv)
    wall = 3.0 + 0.15 - 0.12  # the laser sits 3 cm ahead of the camera
    assert P[0, 2] == pytest.approx(wall)  # above the horizon: the wall
    assert P[1, 2] == pytest.approx(CAMERA_HEIGHT * f / 110.0)  # the floor, nearer
    assert P[2, 2] == pytest.approx(wall)  # the floor lies beyond the wall there
    assert P[1, 1] == pytest.approx(CAMERA_HEIGHT)  # on the floor: 1 m below the camera
    ground = vp.depth_points(0, uv, upper=False)
    assert np.isnan(ground[0]).all() and np.allclose(ground[1:], P[1:])
    _Map.scans = np.full((1, 181), np.inf)  # nothing within range: far
    assert vp.depth_points(0, uv)[0, 2] == pytest.approx(40.0)


def test_pose_beside_and_behind_a_view_is_metric(servo_maps):
    """Rendered beside, behind and turned from hallway and lawn views: most are posed, the
    offset across within 0.1 m typically (median) and the heading within 0.02 rad, where the
    whole image's shift cannot tell the offset from the heading."""
    errors = []
    for world, views in (("hallway", (10, 130)), ("lawn", (60, 122))):
        m = servo_maps[world]
        vp = ViewPose(m)
        env = ServoEnv(world, m)
        try:
            for view in views:
                assert vp.depth_model(view) is not None
                for true in ((-1.0, 0.5, 0.0), (-1.5, -0.4, 0.08), (0.4, 0.3, -0.05)):
                    rel = vp.pose(_rendered(env, m, view, *true), view)
                    if rel is not None:  # too few keypoints agree: no pose, no harm
                        errors.append(np.abs(rel.pose - true))
        finally:
            env.close()
    errors = np.array(errors)
    assert len(errors) >= 8  # of 12
    # a rare pose is far off (keypoints matched on a repeated texture: lawn view 60 at
    # (-1, 0.5) gives 1.4 m across); the controller takes a pose only where the next agrees
    good = errors[:, 1] < 0.3
    assert good.sum() >= len(errors) - 1
    assert np.median(errors[:, :2], axis=0).max() < 0.1 and errors[good, 2].max() < 0.02


def test_the_map_check_compares_poses_with_the_scan_matched_links(servo_maps):
    """A view is used only where the poses of its linked views against it agree with the
    view graph's links: with every link moved 0.5 m along, none does; with the depths of
    the scan three times too long, the view falls back to the floor's keypoints."""
    m = servo_maps["hallway"]
    assert ViewPose(m).depth_model(10) is not None
    moved = ViewPose(replace(m, edge_transforms=m.edge_transforms + [0.5, 0.0, 0.0]))
    assert moved.depth_model(10) is None
    assert moved.pose(m.images[11], 10) is None
    far = ViewPose(replace(m, scans=m.scans * 3.0))
    assert far.depth_model(10) == "ground" and not far._agrees(10, True, 0.25)


def test_view_pose_refuses_bad_input(servo_maps):
    m = servo_maps["hallway"]
    vp = ViewPose(m)
    with pytest.raises(ValueError, match="image"):
        vp.relative(np.zeros((240, 320), np.uint8), 10)
    with pytest.raises(ValueError, match="image"):
        vp.relative(np.zeros((240, 320, 3), np.float32), 10)
    with pytest.raises(MapError, match="view"):
        vp.relative(m.images[0], len(m))
    with pytest.raises(ValueError, match="n_features"):
        ViewPose(m, n_features=2)
    with pytest.raises(TypeError, match="ServoMap"):
        ViewPose(m.images)
    # a blank image has no keypoints: no pose, no error
    assert vp.relative(np.zeros((240, 320, 3), np.uint8), 10) is None


def test_fix_pose_moves_position_and_heading_and_ignores_outliers():
    b = RouteBelief(RoutePath(L_FRAMES), [2.0, 0.0, 0.0])
    # measured: 0.4 m behind view 3 and 0.5 m left of it, turned 0.1 rad
    measured = b.measured(3, [-0.4, 0.5, 0.1])
    np.testing.assert_allclose(measured, [2.6, 0.5, 0.1])
    d = b.fix_pose(measured, gain=0.5, gate=1.0)
    assert d == pytest.approx(np.hypot(0.6, 0.5))
    np.testing.assert_allclose(b.pose, [2.3, 0.25, 0.05])
    before = b.pose.copy()
    assert np.isnan(b.fix_pose(b.measured(5, [0.0, 0.0, 0.0]), gain=0.5, gate=1.0))  # 2.7 m
    np.testing.assert_array_equal(b.pose, before)


def test_pose_fixes_are_on_by_default_and_validated(servo_maps):
    assert isinstance(SignalServo(servo_maps["hallway"]).poses.view_pose, ViewPose)
    assert SignalServo(servo_maps["hallway"], config=SignalServoConfig(pose_every=0)).poses is None
    assert SignalServoConfig().fix_check == 8 and SignalServoConfig(fix_check=0).fix_check == 0
    for bad in (
        {"pose_every": -1},
        {"pose_gain": 1.5},
        {"pose_gate": 0.0},
        {"pose_agree": -0.1},
        {"fix_check": -1},
        {"fix_check": 2.5},
    ):
        with pytest.raises(ValueError, match=next(iter(bad))):
            SignalServoConfig(**bad)


def test_pose_agreement_takes_a_pose_only_when_the_last_one_carried_agrees():
    a = PoseAgreement(0.3)
    assert not a.agrees([1.0, 0.0, 0.0], [5.0, 5.0, np.pi / 2])  # nothing to agree with
    # odometry: 0.5 m ahead (its own frame turned 90 deg); the route frame: +x
    assert a.agrees([1.5, 0.05, 0.02], [5.0, 5.5, np.pi / 2])
    assert not a.agrees([3.0, 0.0, 0.0], [5.0, 5.5, np.pi / 2])  # 1.5 m off: an outlier
    assert not a.agrees([1.5, 0.0, 0.0], [5.0, 5.5, np.pi / 2])  # against the outlier
    assert a.agrees([1.5, 0.0, 0.0], [5.0, 5.5, np.pi / 2])
    assert not a.agrees([1.5, 0.0, 0.3], [5.0, 5.5, np.pi / 2])  # turned 0.3 rad
    a.reset()
    assert not a.agrees([1.5, 0.0, 0.0], [5.0, 5.5, np.pi / 2])
    with pytest.raises(ValueError, match="distance"):
        PoseAgreement(0.0)


def test_the_start_pose_comes_from_two_agreeing_turn_images(servo_maps):
    """``pose_start``: the belief starts where the turn's two images that matched the fix's
    view best pose the robot, carried by odometry to now; where they disagree, nowhere."""
    from servo.camera_only.metric_pose_fixes import PoseFixes

    m = servo_maps["hallway"]
    config = SignalServoConfig(pose_every=3, pose_start=True, pose_agree=0.3)
    fixes = PoseFixes(ViewPose(m), config)
    path = RoutePath(L_FRAMES)
    odo_turn = [0.0, 0.0, 0.3]
    for image in (m.images[40], m.images[10], m.images[10]):  # the first matched worst
        fixes.observe(image, odo_turn)
    now = se2_compose(odo_turn, [1.0, 0.0, 0.0])  # then 1 m ahead
    start = fixes.start(10, np.array([0.9, 0.1, 0.2]), path, now)
    np.testing.assert_allclose(start, [1.0, 0.0, 0.0], atol=0.02)
    assert fixes.turn_images == []  # used up
    for image in (m.images[10], m.images[10]):
        fixes.observe(image, odo_turn)
    # the second image seen 0.5 rad later by odometry: the two poses disagree
    fixes.turn_images[1] = (fixes.turn_images[1][0], np.array([0.0, 0.0, 0.8]))
    assert fixes.start(10, np.array([0.1, 0.2]), path, now) is None
    off = PoseFixes(ViewPose(m), SignalServoConfig(pose_start=False))
    off.observe(m.images[10], odo_turn)
    assert off.turn_images == [] and off.start(10, np.array([0.1]), path, now) is None


def test_the_turn_supports_a_fix_where_its_two_best_images_pose_and_agree(servo_maps):
    """``PoseFixes.supports`` (``fix_check``): the two turn images that matched a view best
    pose against it and agree, carried by odometry; not where they disagree, where one does
    not pose (another place's image) or where no images were kept. It leaves the turn's
    images for ``start``."""
    from servo.camera_only.metric_pose_fixes import PoseFixes

    m = servo_maps["hallway"]
    fixes = PoseFixes(ViewPose(m), SignalServoConfig(pose_every=3, pose_start=True))
    odo = [0.0, 0.0, 0.3]
    for image in (m.images[40], m.images[10], m.images[10]):
        fixes.observe(image, odo)
    assert fixes.supports(10, np.array([0.9, 0.1, 0.2]))
    assert not fixes.supports(10, np.array([0.1, 0.9, 0.2]))  # image 40 is not at view 10
    assert len(fixes.turn_images) == 3
    fixes.turn_images[2] = (fixes.turn_images[2][0], np.array([0.0, 0.0, 0.8]))
    assert not fixes.supports(10, np.array([0.9, 0.1, 0.2]))  # 0.5 rad apart by odometry
    assert not fixes.supports(10, np.array([0.1]))  # not one distance per kept image
    off = PoseFixes(ViewPose(m), SignalServoConfig(pose_start=False))
    off.observe(m.images[10], odo)
    off.observe(m.images[10], odo)
    assert not off.supports(10, np.array([0.1, 0.2]))
