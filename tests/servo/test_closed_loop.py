"""Real episodes: the controller reaches stored views across manifolds in both worlds, every
branch as start and as target; the oracle reaches the same ones (so the tasks are feasible)."""

import numpy as np
import pytest

from scenes import MANIFOLDS
from servo.baselines import GreedyFProbing, OraclePolicy, RandomPolicy
from servo.controller import ManifoldServo
from servo.env import ServoEnv
from servo.evaluate import run_episode

TASKS = {  # (start manifold, target manifold): every branch as a start and as a target
    "hallway": [
        ("hallway-left", "hallway-right"),
        ("hallway-right", "hallway-straight"),
        ("hallway", "hallway-left"),
    ],
    "lawn": [
        ("lawn-left", "lawn-right"),
        ("lawn-right", "lawn-straight"),
        ("lawn-straight", "lawn-left"),
    ],
}
# Driving the straight branch's recording backwards and turning into a side branch: the scans
# share only side walls with the stored views, and the position along the corridor comes from
# the local map of the route's scans (the junction ahead). Straight -> left passes since then;
# straight -> right still fails (strict xfail, so a fix shows up): global localisation in the
# uniform straight branch starts 2 m off along it, more than a tracking correction may move.
BACKWARDS = [("hallway", "hallway-straight", "hallway-left")]
KNOWN_FAILURES = [("hallway", "hallway-straight", "hallway-right")]
CASES = [(w, a, b) for w, pairs in TASKS.items() for a, b in pairs] + BACKWARDS + KNOWN_FAILURES
SERVO_CASES = [
    pytest.param(*c, marks=pytest.mark.xfail(strict=True, reason="see KNOWN_FAILURES"))
    if c in KNOWN_FAILURES
    else c
    for c in CASES
]


def middle_view(servo_map, manifold: str) -> int:
    views = np.flatnonzero(servo_map.true_labels == MANIFOLDS.index(manifold))
    return int(views[len(views) // 2])


@pytest.fixture(scope="module")
def envs(servo_maps):
    out = {w: ServoEnv(w, m, max_steps=500) for w, m in servo_maps.items()}
    yield out
    for e in out.values():
        e.close()


def _options(env, start, target):
    return {"start_view": middle_view(env.map, start), "target": middle_view(env.map, target)}


@pytest.mark.parametrize("world, start, target", SERVO_CASES)
def test_servo_reaches_the_target(envs, world, start, target):
    env = envs[world]
    record = run_episode(env, ManifoldServo(env.map, world=world), 11, _options(env, start, target))
    assert (record["start_manifold"], record["target_manifold"]) == (start, target)
    assert record["success"], record
    assert record["spl"] > 0.5


@pytest.mark.parametrize("world, start, target", CASES)
def test_oracle_reaches_the_target(envs, world, start, target):
    env = envs[world]
    record = run_episode(env, OraclePolicy(env.base.world), 11, _options(env, start, target))
    assert record["success"], record
    assert record["spl"] > 0.8


def test_controller_is_deterministic(envs):
    env = envs["lawn"]

    def actions():
        obs, info = env.reset(seed=5)
        ctl = ManifoldServo(env.map)
        ctl.reset(info["target_view"])
        out = []
        for _ in range(25):
            out.append(ctl.act(obs))
            obs, *_ = env.step(out[-1])
        return np.array(out)

    np.testing.assert_array_equal(actions(), actions())


def test_controller_needs_no_truth(envs):
    """act() never reads info: poisoning it changes nothing."""
    env = envs["hallway"]
    obs, info = env.reset(seed=2)
    a, b = ManifoldServo(env.map), ManifoldServo(env.map)
    a.reset(info["target_view"])
    b.reset(info["target_view"], {"pose": np.full(3, np.nan)})
    np.testing.assert_array_equal(a.act(obs), b.act(obs, {"pose": np.full(3, np.nan)}))


def test_controller_bad_inputs(servo_maps):
    ctl = ManifoldServo(servo_maps["hallway"])
    obs = {
        "image": np.zeros((240, 320, 3), np.uint8),
        "scan": np.ones(361, np.float32),
        "odometry": np.zeros(3),
    }
    with pytest.raises(RuntimeError, match="reset"):
        ctl.act(obs)
    with pytest.raises(ValueError, match="target"):
        ctl.reset(len(servo_maps["hallway"]))
    ctl.reset(0)
    with pytest.raises(ValueError, match=r"observation\['image'\] must have shape"):
        ctl.act({**obs, "image": np.zeros((60, 80, 3), np.uint8)})
    with pytest.raises(ValueError, match=r"observation\['scan'\]"):
        ctl.act({**obs, "scan": np.ones(180, np.float32)})
    with pytest.raises(ValueError, match="odometry"):
        ctl.act({k: v for k, v in obs.items() if k != "odometry"})


def test_baselines_run(envs):
    env = envs["hallway"]
    for policy in (GreedyFProbing(env.map), RandomPolicy(np.random.default_rng(0))):
        obs, info = env.reset(seed=4)
        policy.reset(info["target_view"], info)
        for _ in range(15):
            a = policy.act(obs, info)
            assert env.action_space.contains(np.asarray(a, np.float32))
            obs, _, _, _, info = env.step(a)
