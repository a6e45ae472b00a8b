"""The policy template and the two outside baselines in ``examples/`` have the interface the
servo benchmark runs, and run an episode without failing it."""

import numpy as np
import pytest

from servo.task.env import ServoEnv
from servo.task.evaluation import make_policy, run_episode
from servo.task.interface import Policy

SPECS = (
    "examples.my_policy:make_policy",
    "examples.nearest_view_homing:make_policy",
    "examples.image_descent:make_policy",
)


@pytest.fixture(scope="module")
def env(servo_maps):
    env = ServoEnv("hallway", servo_maps["hallway"], max_steps=8)
    yield env
    env.close()


@pytest.mark.parametrize("spec", SPECS)
def test_an_example_is_a_policy_and_runs(env, spec):
    policy = make_policy(spec, env, np.random.default_rng(0))  # in its own process
    assert isinstance(policy, Policy)
    try:
        record = run_episode(env, policy, seed=5)
    finally:
        policy.close()
    assert "failure" not in record, record.get("failure")
    assert record["steps"] == 8 and record["path_length"] > 0  # it drove


def test_the_homing_turns_back_toward_a_view_it_turned_away_from(env):
    """The alignment's sign: after turning left, the view seen before lies to the right."""
    from examples.nearest_view_homing import _features, _shift

    obs, _ = env.reset(seed=3)
    before = _features(obs["image"])[0]
    for _ in range(3):
        obs, *_ = env.step(np.array([0.0, 1.0], np.float32))
    shift, score = _shift(_features(obs["image"])[0], before)
    assert shift > 0 and score > 0.3
