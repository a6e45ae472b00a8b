import warnings

import gymnasium as gym
import numpy as np
import pytest
from gymnasium.utils.env_checker import check_env

import sim  # noqa: F401  (registers the envs)
from sim.camera import CameraConfig

# check_env's advice we deliberately do not take: (v, omega) keep their physical units, and
# a laser beam with no return is +inf (REP 117), so the scan box is unbounded above.
EXPECTED_WARNINGS = ("symmetric and normalized space", "maximum value is infinity")
SMALL = {"camera": CameraConfig(width=64, height=48)}


@pytest.mark.parametrize("env_id", ["topomap/Hallway-v0", "topomap/Lawn-v0"])
def test_check_env_passes_without_unexpected_warnings(env_id):
    env = gym.make(env_id, render_mode="rgb_array", **SMALL)
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        check_env(env.unwrapped)
    unexpected = [
        str(w.message) for w in caught if not any(e in str(w.message) for e in EXPECTED_WARNINGS)
    ]
    assert unexpected == []
    env.reset(seed=0)
    frame = env.render()
    assert frame.ndim == 3 and frame.dtype == np.uint8 and frame.std() > 10
    env.close()
    env.close()


def _rollout(seed: int):
    env = gym.make("topomap/Hallway-v0", randomize=True, **SMALL)
    obs, info = env.reset(seed=seed)
    images, scans, poses = [obs["image"]], [obs["scan"]], [info["pose"]]
    env.action_space.seed(seed)
    for _ in range(15):
        obs, _, _, _, info = env.step(env.action_space.sample())
        images.append(obs["image"])
        scans.append(obs["scan"])
        poses.append(info["pose"])
    env.close()
    return np.array(images), np.array(scans), np.array(poses)


def test_same_seed_same_observations_bit_for_bit():
    a, b, c = _rollout(5), _rollout(5), _rollout(6)
    for x, y in zip(a, b, strict=True):
        np.testing.assert_array_equal(x, y)
    assert not np.array_equal(a[2], c[2])


def test_actions_are_validated_and_clipped():
    env = gym.make("topomap/Lawn-v0", sensors=("scan",))
    env.reset(seed=0, options={"pose": (5.0, 0.0, 0.0)})
    with pytest.raises(ValueError, match=r"action must have shape \(2,\)"):
        env.step(np.zeros(3))
    with pytest.raises(ValueError, match="action must be finite"):
        env.step(np.array([np.nan, 0.0]))
    for _ in range(10):
        _, _, _, _, info = env.step(np.array([100.0, 0.0]))  # clipped to 1.5 m/s
    assert info["pose"][0] == pytest.approx(5.0 + 1.5, abs=0.1)
    assert info["manifold"] == "lawn"
    env.close()


def test_bad_arguments_name_the_choices():
    with pytest.raises(ValueError, match="world must be one of"):
        gym.make("topomap/Hallway-v0", world="moon")
    with pytest.raises(ValueError, match="sensors must be a non-empty subset"):
        gym.make("topomap/Hallway-v0", sensors=("sonar",))
    with pytest.raises(ValueError, match="appearance must be one of"):
        gym.make("topomap/Hallway-v0", appearance="dark")
    env = gym.make("topomap/Hallway-v0", sensors=("scan",))
    with pytest.raises(ValueError, match="not in free space"):
        env.reset(seed=0, options={"pose": (5.0, 3.0, 0.0)})
    with pytest.raises(ValueError, match="manifold must be one of"):
        env.reset(seed=0, options={"manifold": "attic"})
    obs, info = env.reset(seed=0, options={"manifold": "hallway-right"})
    assert info["manifold"] == "hallway-right" and set(obs) == {"scan"}
    env.close()


def test_async_vector_env_runs():
    envs = gym.vector.AsyncVectorEnv(
        [lambda: gym.make("topomap/Hallway-v0", **SMALL) for _ in range(2)], context="spawn"
    )
    try:
        obs, _ = envs.reset(seed=[1, 2])
        assert obs["image"].shape == (2, 48, 64, 3)
        for _ in range(3):
            obs, rewards, _, _, _ = envs.step(np.tile([0.5, 0.1], (2, 1)).astype(np.float32))
        assert obs["scan"].shape == (2, 361) and rewards.shape == (2,)
    finally:
        envs.close()


_FORK_AFTER_RENDER = """
import sim, gymnasium as gym
from sim.camera import CameraConfig
small = {"camera": CameraConfig(width=64, height=48)}
env = gym.make("topomap/Hallway-v0", **small)
env.reset(seed=0)  # the parent now holds a GL context
env.close()
envs = gym.make_vec("topomap/Hallway-v0", num_envs=2, vectorization_mode="async",
                    vector_kwargs={"context": "fork"}, **small)
try:
    obs, _ = envs.reset(seed=0)
    print("ok", obs["image"].shape)
finally:
    envs.close()
"""


@pytest.mark.parametrize("threads", [None, "2"])
def test_forked_vector_env_after_rendering_works_or_fails_at_once(threads):
    """The default (fork) context after the parent rendered: works with sim's default
    ``LP_NUM_THREADS=0``; with render threads on, fails at once saying to use spawn. A fresh
    interpreter, since Mesa reads the variable once; the timeout turns a hang into a failure."""
    import os
    import subprocess
    import sys

    env = {k: v for k, v in os.environ.items() if k != "LP_NUM_THREADS"}
    if threads:
        env["LP_NUM_THREADS"] = threads
    run = subprocess.run(
        [sys.executable, "-c", _FORK_AFTER_RENDER],
        env=env, capture_output=True, text=True, timeout=240,
    )  # fmt: skip
    if threads is None:
        assert run.returncode == 0 and "ok (2, 48, 64, 3)" in run.stdout, run.stderr[-2000:]
    else:
        assert run.returncode != 0
        assert "forked after its parent created an OpenGL context" in run.stderr
        assert "'context': 'spawn'" in run.stderr
