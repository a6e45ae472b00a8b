"""``ServoEnv``'s success test, reward and episode end on a scripted robot and a stub map.

The env's ``reset`` and ``step`` run as they are; only what they read is replaced: the plain
navigation env by a robot that follows a given list of poses and contacts, and the servo map
by the stored views it needs, whose eq. 13 signal is the image's mean grey level. Each test
takes milliseconds, so every step of an episode can be checked against numbers worked by hand.
"""

import numpy as np
import pytest

from servo.task.env import (
    COLLISION_PENALTY,
    STUCK_DISTANCE,
    STUCK_WINDOW,
    SUCCESS_HEADING,
    SUCCESS_RADIUS,
    SUCCESS_REWARD,
    ServoEnv,
)

SHAPE = (2, 2, 3)


def _image(level):
    return np.full(SHAPE, level, np.uint8)


class _Features:
    def transform(self, images):
        return images.reshape(len(images), -1).mean(axis=1, keepdims=True)


class _Clustering:
    def signal(self, x, cluster, target):
        return x[:, 0].astype(np.float64)


class _Map:
    """Two stored views: view 0 on the hallway, view 1 (the target, grey 200) at the origin."""

    world = "hallway"
    images = np.stack([_image(40), _image(200)])
    scans = np.ones((2, 4), np.float32)
    true_poses = np.array([[5.0, 0.0, 0.0], [0.0, 0.0, 0.0]])
    true_labels = np.array([0, 1])
    clusters = np.array([0, 1])
    image_features = _Features()
    clustering = _Clustering()

    def __len__(self):
        return 2

    def check_view(self, view, name="target"):
        return int(view)

    def true_manifold(self, view):
        return ("hallway", "hallway-left")[view]


class _Sim:
    pose = np.zeros(3)


class _Robot:
    """``NavigationEnv`` as the servo env reads it, moving along ``script``: one (pose,
    collision, grey level) per step."""

    def __init__(self, script):
        self.script = list(script)
        self.sim = _Sim()
        self.actions = []

    def _info(self, pose, collision):
        return {
            "pose": pose,
            "odometry": pose.copy(),
            "collision": collision,
            "manifold": "hallway",
        }

    def reset(self, seed=None, options=None):
        self.k = 0
        self.sim.pose = np.asarray(options["pose"], float)
        return {"image": _image(40)}, self._info(self.sim.pose, False)

    def step(self, action):
        self.actions.append(action)
        pose, collision, level = self.script[self.k]
        self.k += 1
        self.sim.pose = np.asarray(pose, float)
        return {"image": _image(level)}, 0.0, False, False, self._info(self.sim.pose, collision)

    def scan_observation(self, ranges, key):
        return {key: ranges}


def _env(script, max_steps=50, **weights):
    env = ServoEnv.__new__(ServoEnv)
    env.map, env.base, env.max_steps, env.cross_manifold = _Map(), _Robot(script), max_steps, True
    env.signal_weight = weights.get("signal_weight", 1.0)
    env.success_reward = weights.get("success_reward", SUCCESS_REWARD)
    env.collision_penalty = weights.get("collision_penalty", COLLISION_PENALTY)
    env.render_mode = None
    return env


def _run(env, start):
    _, info = env.reset(seed=0, options={"pose": np.asarray(start, float), "target": 1})
    steps = []
    for k, _ in enumerate(env.base.script):
        action = np.array([0.1, 0.01 * k], np.float32)
        steps.append(env.step(action))
        assert env.base.actions[-1] is action  # the robot is given the action
        if steps[-1][2] or steps[-1][3]:
            break
    return info, steps


def test_reset_reports_the_task_and_the_normalised_signal():
    info, _ = _run(_env([]), (3.0, 4.0, 0.5))
    assert info["target_view"] == 1 and info["target_manifold"] == "hallway-left"
    assert info["start_manifold"] == "hallway" and info["path_length"] == 0.0
    np.testing.assert_array_equal(info["target_pose"], [0.0, 0.0, 0.0])
    assert info["distance"] == pytest.approx(5.0) and info["heading_error"] == pytest.approx(0.5)
    assert info["signal"] == pytest.approx(40 / 200) and info["success"] is False
    assert info["reason"] is None


def test_reward_is_the_signal_gain_plus_arrival_and_contact_terms():
    script = [
        ((2.0, 0.0, 0.0), False, 100),
        ((1.0, 0.0, 0.0), True, 80),
        ((0.5, 0.0, -0.3), False, 190),
    ]
    env = _env(script, signal_weight=2.0, success_reward=3.0, collision_penalty=0.25)
    _, steps = _run(env, (3.0, 0.0, 0.0))
    parts = np.array(
        [[s[4]["reward_signal"], s[4]["reward_success"], s[4]["reward_collision"]] for s in steps]
    )
    np.testing.assert_allclose(
        parts,
        [[2.0 * 60 / 200, 0.0, 0.0], [2.0 * -20 / 200, 0.0, -0.25], [2.0 * 110 / 200, 3.0, 0.0]],
        atol=1e-12,
    )
    np.testing.assert_allclose([s[1] for s in steps], parts.sum(axis=1), atol=1e-12)
    assert [s[4]["signal"] for s in steps] == pytest.approx([0.5, 0.4, 0.95])
    # 1 m, 1 m, then 0.5 m: the path walked, and the last pose within 0.5 m and 0.3 rad
    assert steps[-1][4]["path_length"] == pytest.approx(2.5)
    assert steps[-1][4]["distance"] == pytest.approx(0.5)
    assert steps[-1][2] is True and steps[-1][3] is False and steps[-1][4]["reason"] == "success"


@pytest.mark.parametrize(
    ("pose", "success"),
    [
        ((SUCCESS_RADIUS, 0.0, 0.0), True),  # the radius is inclusive
        ((0.0, -SUCCESS_RADIUS, SUCCESS_HEADING - 1e-12), True),
        ((0.0, 0.0, -SUCCESS_HEADING + 1e-12), True),
        ((np.nextafter(SUCCESS_RADIUS, 1.0), 0.0, 0.0), False),
        ((0.0, 0.0, SUCCESS_HEADING + 1e-12), False),
        ((0.3, 0.0, -1.0), False),  # near, facing away
        ((2.0, 0.0, 0.0), False),  # facing the right way, far
    ],
)
def test_success_needs_both_the_radius_and_the_heading(pose, success):
    _, (step,) = _run(_env([(pose, False, 100)]), (3.0, 0.0, 0.0))
    _, reward, terminated, truncated, info = step
    assert info["success"] is success and terminated is success and truncated is False
    assert info["reward_success"] == (SUCCESS_REWARD if success else 0.0)
    assert reward == pytest.approx(info["reward_signal"] + info["reward_success"])
    assert info["reason"] == ("success" if success else None)


def test_pushing_a_wall_ends_as_stuck_after_the_window():
    # in contact every step, creeping 0.003 m a step: 29 steps move 0.087 m < STUCK_DISTANCE
    script = [((3.0 - 0.003 * k, 0.0, 0.0), True, 40) for k in range(1, 40)]
    _, steps = _run(_env(script), (3.0, 0.0, 0.0))
    assert len(steps) == STUCK_WINDOW
    assert [s[4]["stuck"] for s in steps] == [False] * (STUCK_WINDOW - 1) + [True]
    assert steps[-1][2] and not steps[-1][3] and steps[-1][4]["reason"] == "stuck"
    assert steps[0][1] == pytest.approx(-COLLISION_PENALTY)


def test_contact_while_moving_or_a_break_in_contact_is_not_stuck():
    moving = [((3.0 - 0.004 * k, 0.0, 0.0), True, 40) for k in range(1, 40)]  # 0.116 m in 29
    _, steps = _run(_env(moving, max_steps=39), (3.0, 0.0, 0.0))
    assert not any(s[4]["stuck"] for s in steps) and steps[-1][4]["reason"] == "time limit"
    assert 29 * 0.004 >= STUCK_DISTANCE
    still = [((3.0, 0.0, 0.0), k != 10, 40) for k in range(1, 50)]  # free at step 10
    _, steps = _run(_env(still, max_steps=49), (3.0, 0.0, 0.0))
    stuck_at = [k for k, s in enumerate(steps, start=1) if s[4]["stuck"]]
    assert stuck_at == [10 + STUCK_WINDOW]


def test_the_step_limit_truncates_unless_the_last_step_arrives():
    far = [((3.0, 0.0, 0.0), False, 40)] * 3
    _, steps = _run(_env(far, max_steps=3), (3.0, 0.0, 0.0))
    assert [(s[2], s[3]) for s in steps] == [(False, False), (False, False), (False, True)]
    assert steps[-1][4]["reason"] == "time limit"
    arrive = far[:2] + [((0.0, 0.0, 0.0), False, 200)]
    _, steps = _run(_env(arrive, max_steps=3), (3.0, 0.0, 0.0))
    assert (steps[-1][2], steps[-1][3], steps[-1][4]["reason"]) == (True, False, "success")


def test_the_stuck_test_spans_the_whole_window():
    # in contact throughout; moving exactly STUCK_DISTANCE over the window is moving
    still = [((3.0, 0.0, 0.0), True, 40)] * (STUCK_WINDOW - 1)
    _, steps = _run(_env([*still, ((3.0, STUCK_DISTANCE, 0.0), True, 40)]), (3.0, 0.0, 0.0))
    assert not steps[-1][4]["stuck"]
    # a move at the second step is in the window until the window has passed it
    moved = [((3.0, 0.0, 0.0), True, 40)] + [((3.0, 0.15, 0.0), True, 40)] * 40
    _, steps = _run(_env(moved), (3.0, 0.0, 0.0))
    assert [k for k, s in enumerate(steps, start=1) if s[4]["stuck"]] == [STUCK_WINDOW + 1]
