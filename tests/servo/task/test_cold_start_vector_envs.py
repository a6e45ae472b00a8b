"""Vector envs started on an empty data home: their workers are daemonic processes, which may
start no children, so the default dataset is collected in the worker's own process, by one
worker under the home's lock, and the servo map built once; the other waits and loads both.
About a minute and a quarter each on 2 cores (the default dataset collected in one process):
marked ``slow`` (``-m "not slow"`` leaves them out)."""

import os

import gymnasium as gym
import numpy as np
import pytest

import servo  # noqa: F401  (registers the servo ids)

ENV_ID = "topomap/HallwayServo-v0"


def make_servo_env():
    """One worker's env (the worker imports this module by name, which registers the id)."""
    return gym.make(ENV_ID, max_steps=5)


def _check_home(home):
    assert sorted(p.name for p in (home / "dataset").iterdir() if p.suffix == ".npz")
    maps = [p for p in (home / "servo-maps").iterdir() if p.suffix == ".npz"]
    assert len(maps) == 1 and maps[0].name.startswith("hallway-")  # built once


@pytest.fixture
def empty_home(tmp_path, monkeypatch):
    home = tmp_path / "home"
    home.mkdir()
    monkeypatch.setenv("TOPOMAP_HOME", str(home))  # the workers inherit it
    return home


@pytest.mark.slow
def test_gymnasium_async_workers_start_on_an_empty_home(empty_home, capfd):
    envs = gym.make_vec(ENV_ID, num_envs=2, vectorization_mode="async", max_steps=5)
    try:
        obs, _ = envs.reset(seed=0)
        assert obs["image"].shape == (2, 240, 320, 3)
        for _ in range(6):
            _, reward, *_ = envs.step(np.tile([0.5, 0.0], (2, 1)))
            assert np.isfinite(reward).all()
    finally:
        envs.close()
    _check_home(empty_home)
    # Gymnasium makes one env in this process first (for the spaces): that one collects
    assert capfd.readouterr().err.count("collecting the default dataset") == 1


@pytest.mark.slow
def test_stable_baselines3_subprocess_workers_start_on_an_empty_home(empty_home, capfd):
    pytest.importorskip("stable_baselines3")
    from stable_baselines3.common.vec_env import SubprocVecEnv

    envs = SubprocVecEnv([make_servo_env, make_servo_env])
    try:
        obs = envs.reset()
        assert obs["scan"].shape == (2, 361) and os.environ["TOPOMAP_HOME"] == str(empty_home)
        ended = np.zeros(2, bool)
        for _ in range(6):
            _, _, done, _ = envs.step(np.tile([0.5, 0.0], (2, 1)))
            ended |= done
        assert ended.all()  # max_steps=5: each worker's episode ended and was reset
    finally:
        envs.close()
    _check_home(empty_home)
    err = capfd.readouterr().err
    assert err.count("collecting the default dataset") == 1  # one worker; the other waited
    assert "in this process: this process is a daemonic worker" in err
    assert err.count("building the hallway servo map") == 1
