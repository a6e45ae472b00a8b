"""RouteImageFix: the belief corrected by the route view the image matches best, and what it
tells the controller (matched, no match, nothing compared)."""

import numpy as np

from servo.camera_only.controller import SignalServo, SignalServoConfig


def _following(m, start):
    """A controller that fixed on stored view ``start`` and follows a route from it."""
    ahead = (m.sequence == m.sequence[start]) & (m.frame > m.frame[start])
    ctl = SignalServo(m, config=SignalServoConfig(pose_every=0), world=m.world)
    ctl.reset(int(np.flatnonzero(ahead)[-1]))
    yaw = 0.0
    while ctl.phase_ == "observe":
        ctl.act({"image": m.images[start], "odometry": np.array([0.0, 0.0, yaw])})
        yaw += ctl.config.turn_rate * 0.1
    assert ctl.route_[0] == start
    return ctl


def test_a_route_view_image_fixes_a_noise_image_does_not_and_facing_away_compares_none(
    servo_maps,
):
    m = servo_maps["lawn"]  # as in the controller tests: its start is fixed from one image
    ctl = _following(m, 60)
    fixes, odo = ctl.fixes, np.zeros(3)

    def fix(image, pose, **kw):
        ctl.belief_.pose = np.array(pose, float)
        x = ctl.localiser.features(image)
        kw = {"reversing": False, "following": True} | kw
        return fixes.fix(ctl.belief_, ctl.route_, x, image, odo, 1, **kw)

    # the route's first view, the belief 0.1 rad off: matched, the heading pulled toward 0
    assert fix(m.images[60], [0.0, 0.0, 0.1]) is True
    assert abs(ctl.belief_.pose[2]) < 0.1
    noise = np.random.default_rng(0).integers(0, 256, m.images[60].shape, dtype=np.uint8)
    assert fix(noise, [0.0, 0.0, 0.0]) is False  # no view trusted: the controller is lost
    assert fix(m.images[60], [0.0, 0.0, np.pi]) is None  # no route view faces that way
    # reversing in the arrival: metric pose fixes only (none here, pose_every=0)
    assert fix(m.images[60], [0.0, 0.0, 0.1], reversing=True, following=False) is None
    assert ctl.belief_.pose[2] == 0.1
