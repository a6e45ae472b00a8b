"""Pure tests of the junction fix (no rendering)."""

import numpy as np
import pytest

from servo.camera_only.junction_pose import JunctionTurn, pose_from_turn
from servo.camera_only.route_belief import RouteBelief
from servo.route import RoutePath

C = 0.15


def _matches(truth, delta, views, headings):
    """Noise-free shifts of images at belief headings ``headings`` against ``views``, for a
    robot at ``truth`` (x, y) whose true heading is the belief's plus ``delta``."""
    v = np.asarray(views, float)
    lat = -np.sin(v[:, 2]) * (truth[0] - v[:, 0]) + np.cos(v[:, 2]) * (truth[1] - v[:, 1])
    return v[:, 2] - (np.asarray(headings) + delta) - C * lat


def test_three_headings_fix_position_and_heading():
    # a T junction: views looking along the main corridor and into both branches
    views = [(1.0, 0.0, 0.0), (2.0, 0.3, 0.0), (0.0, -1.0, -np.pi / 2), (0.2, 1.0, np.pi / 2)]
    headings = [0.02, 0.0, -1.5, 1.6]
    truth, delta = np.array([0.7, -0.4]), 0.05
    yaws = _matches(truth, delta, views, headings)
    xy, d = pose_from_turn(
        headings, views, yaws, np.ones(4), C, (0.0, 0.0), sigma_xy=100.0, sigma_heading=100.0
    )
    np.testing.assert_allclose(xy, truth, atol=1e-4)
    assert d == pytest.approx(delta, abs=1e-4)


def test_two_headings_fix_the_position_where_the_heading_is_known():
    # two perpendicular headings: a heading offset trades against a diagonal shift, so the
    # heading's prior decides it (odometry's heading after reversing is good to ~0.1 rad)
    views = [(1.0, 0.0, 0.0), (2.0, 0.3, 0.0), (0.0, -1.0, -np.pi / 2), (0.2, -2.0, -np.pi / 2)]
    headings = [0.02, 0.0, -1.5, -1.6]
    truth = np.array([0.7, -0.4])
    yaws = _matches(truth, 0.0, views, headings)
    xy, d = pose_from_turn(
        headings, views, yaws, np.ones(4), C, (0.0, 0.0), sigma_xy=100.0, sigma_heading=0.001
    )
    np.testing.assert_allclose(xy, truth, atol=1e-3)
    assert abs(d) < 1e-3


def test_one_heading_leaves_the_position_along_its_sight_to_the_prior():
    views = [(1.0, 0.0, 0.0), (2.0, 0.3, 0.0), (3.0, 0.1, 0.0)]
    headings = [0.0, 0.1, -0.1]
    yaws = _matches(np.array([0.5, 0.4]), 0.0, views, headings)
    xy, _ = pose_from_turn(headings, views, yaws, np.ones(3), C, (-0.8, 0.0), sigma_heading=0.01)
    assert xy[0] == pytest.approx(-0.8, abs=1e-6)  # along the views' sight: the prior
    assert xy[1] == pytest.approx(0.4, abs=0.05)  # across: fixed (heading held by its prior)


def test_no_weight_returns_the_prior_and_bad_input_is_refused():
    xy, d = pose_from_turn([0.0], [(1.0, 0.0, 0.0)], [0.3], [0.0], C, (0.2, -0.1))
    np.testing.assert_allclose(xy, [0.2, -0.1])
    assert d == 0.0
    with pytest.raises(ValueError):
        pose_from_turn([0.0], [(1.0, 0.0, 0.0)], [0.3], [1.0], 0.0, (0, 0))
    with pytest.raises(ValueError):
        pose_from_turn([0.0, 1.0], [(1.0, 0.0, 0.0)], [0.3], [1.0], C, (0, 0))
    with pytest.raises(ValueError):
        pose_from_turn([0.0], [(1.0, 0.0, 0.0)], [0.3], [-1.0], C, (0, 0))


class _Aligner:
    """Stands in for ImageLocaliser.align: the shifts a robot at ``truth`` would see."""

    def __init__(self, poses, truth):
        self.poses, self.truth = np.asarray(poses, float), np.asarray(truth, float)
        self.heading = 0.0

    def align(self, x, views):
        v = self.poses[np.asarray(views)]
        return np.full(len(v), 0.1), _matches(self.truth, 0.0, v, np.full(len(v), self.heading))


def test_junction_turn_turns_to_the_heading_then_moves_the_belief():
    path = RoutePath(
        np.array(
            [
                [0.0, 0.0, np.pi],
                [-1.0, 0.0, np.pi],
                [-1.0, -1.0, -np.pi / 2],
                [-1.0, -2.0, -np.pi / 2],
            ]
        )
    )
    poses = np.array(
        [[0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [-1.0, -1.5, -np.pi / 2], [-1.0, -2.5, -np.pi / 2]]
    )
    belief = RouteBelief(path, [-0.4, 0.0, 0.0])  # facing along views 0 and 1 (reversing)
    aligner = _Aligner(poses, truth=(-1.0, 0.0))
    turn = JunctionTurn(np.arange(4), poses, -np.pi / 2, C, trust=0.9, facing=0.6, turn_rate=1.2)
    for _ in range(40):
        aligner.heading = belief.pose[2]
        action = turn.step(belief, None, aligner, 0.1)
        if action is None:
            break
        assert action[0] == 0.0 and action[1] < 0  # on the spot, the short way round
        belief.predict([0.0, 0.0, action[1] * 0.1])
    assert action is None and turn.shift_ is not None
    # two view headings: the heading's prior takes part of the correction (see above)
    assert np.hypot(*(belief.pose[:2] - [-1.0, 0.0])) < 0.25


def test_junction_turn_without_the_fix_only_turns():
    path = RoutePath(np.array([[0.0, 0.0, np.pi], [-1.0, 0.0, np.pi]]))
    belief = RouteBelief(path, [-0.4, 0.0, 0.0])
    turn = JunctionTurn(
        np.zeros(0, np.intp),
        np.zeros((0, 3)),
        np.pi / 2,
        C,
        trust=0.9,
        facing=0.6,
        turn_rate=1.2,
        fix=False,
    )
    for _ in range(40):
        action = turn.step(belief, None, None, 0.1)
        if action is None:
            break
        assert action[0] == 0.0 and action[1] > 0
        belief.predict([0.0, 0.0, action[1] * 0.1])
    assert action is None and turn.shift_ is None
    assert abs(belief.pose[2] - np.pi / 2) < 0.05
    np.testing.assert_allclose(belief.pose[:2], [-0.4, 0.0])
