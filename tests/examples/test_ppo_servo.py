"""The training example's env pipeline, smoked without PyTorch: the images downscaled, the
observations inside their spaces, and Gymnasium's flattening and normalising wrappers (what a
network's input layer sees) free of NaN; PPO itself where Stable-Baselines3 is installed."""

import os
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest
from gymnasium.wrappers import FlattenObservation, NormalizeObservation

from examples.ppo_servo import CNN_SIZE, IMAGE_SIZE, make_env
from servo.maps.file import save_map


@pytest.fixture(scope="module")
def lawn_map_path(servo_maps, tmp_path_factory):
    return str(save_map(servo_maps["lawn"], tmp_path_factory.mktemp("map")))


def _env_args(env_id, lawn_map_path):
    return (env_id, lawn_map_path) if "Servo" in env_id else (env_id, None)


@pytest.mark.parametrize("env_id", ["topomap/Lawn-v0", "topomap/LawnServo-v0"])
def test_the_training_pipeline_gives_no_nan(env_id, lawn_map_path):
    env = make_env(*_env_args(env_id, lawn_map_path))
    images = [k for k in ("image", "target_image") if k in env.observation_space.spaces]
    assert images and all(env.observation_space[k].shape == (*IMAGE_SIZE, 3) for k in images)
    flat = NormalizeObservation(FlattenObservation(env))
    flat.action_space.seed(0)
    obs, _ = flat.reset(seed=0)
    inner, misses = env.unwrapped, 0
    for step in range(40):
        assert np.isfinite(obs).all(), step
        last = inner.base._last_scan if hasattr(inner, "base") else inner._last_scan
        misses += int(np.isinf(last).sum())
        obs, reward, terminated, truncated, _ = flat.step(flat.action_space.sample())
        assert np.isfinite(reward)
        if terminated or truncated:
            obs, _ = flat.reset()
    assert np.isfinite(obs).all()
    assert misses > 0  # beams with no return went through the pipeline
    flat.close()


def test_the_downscaled_observations_lie_in_their_spaces(lawn_map_path):
    env = make_env("topomap/LawnServo-v0", lawn_map_path)
    obs, _ = env.reset(seed=1)
    for _ in range(5):
        assert env.observation_space.contains(obs)
        obs, *_ = env.step(np.array([0.8, 0.3], np.float32))
    env.close()


@pytest.mark.parametrize(
    ("env_id", "obs", "shape"),
    [
        ("topomap/Lawn-v0", "image", (*CNN_SIZE, 1)),
        ("topomap/Lawn-v0", "vector", (40,)),
        ("topomap/LawnServo-v0", "image", (CNN_SIZE[0], 2 * CNN_SIZE[1], 1)),
        ("topomap/LawnServo-v0", "vector", (76,)),
    ],
)
def test_the_one_box_observations_lie_in_their_spaces(env_id, obs, shape, lawn_map_path):
    env = make_env(*_env_args(env_id, lawn_map_path), obs=obs)
    assert env.observation_space.shape == shape
    if obs == "vector" and "Servo" not in env_id:
        assert "image" not in env.unwrapped.observation_space.spaces  # no camera rendered
    o, _ = env.reset(seed=1)
    for _ in range(3):
        assert env.observation_space.contains(o)
        o, *_ = env.step(np.array([0.8, 0.3], np.float32))
    env.close()


@pytest.mark.parametrize("obs", ["image", "vector", "dict"])
def test_ppo_trains_a_few_steps(lawn_map_path, obs):
    """Where the optional extra is installed (pip install -e ".[rl]"); CI has no PyTorch."""
    pytest.importorskip("stable_baselines3")
    from examples.ppo_servo import train

    out = train("topomap/LawnServo-v0", 128, lawn_map_path, obs=obs)
    assert out["steps"] >= 128 and out["steps_per_s"] > 0 and out["obs"] == obs


def test_the_example_runs_from_a_folder_outside_the_repository(tmp_path):
    """``python examples/ppo_servo.py`` by its path, the working folder elsewhere; the
    project on the import path as an install puts it."""
    root = Path(__file__).resolve().parents[2]
    env = {
        **os.environ,
        "PYTHONPATH": os.pathsep.join([str(root), *filter(None, [os.environ.get("PYTHONPATH")])]),
    }
    script = str(root / "examples" / "ppo_servo.py")
    done = subprocess.run(
        [sys.executable, script, "--help"],
        cwd=tmp_path,
        env=env,
        capture_output=True,
        text=True,
        timeout=120,
    )
    assert done.returncode == 0, done.stderr
    assert "--obs {image,vector,dict}" in done.stdout


def test_an_episode_went_well_by_the_envs_own_terms():
    from examples.ppo_servo import episode_outcome

    assert episode_outcome({"success": True}, 3.5) == (3.5, True)
    assert episode_outcome({"success": False}, 3.5) == (3.5, False)
    # a navigation episode never terminates: it went well when it hit nothing
    assert episode_outcome({"collision": False}, 0.0) == (0.0, True)
    assert episode_outcome({"collision": False}, -2.0) == (-2.0, False)


def test_the_learning_curve_is_drawn_with_its_numbers(tmp_path):
    import json

    from examples.ppo_servo import plot_curve

    ended = [
        {"step": 200 * (i + 1), "return": -5.0 + i / 4, "ok": i > 12, "metres": 3.0 + i}
        for i in range(20)
    ]
    result = {"env": "topomap/Hallway-v0", "obs": "vector", "steps": 4000, "episodes_detail": ended}
    plot_curve(result, str(tmp_path / "curve" / "ppo.png"))
    assert (tmp_path / "curve" / "ppo.png").read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    assert json.loads((tmp_path / "curve" / "ppo.json").read_text()) == result
    assert sorted(p.name for p in (tmp_path / "curve").iterdir()) == ["ppo.json", "ppo.png"]
    with pytest.raises(ValueError, match="no episode ended in 4000 steps"):
        plot_curve({**result, "episodes_detail": []}, str(tmp_path / "empty.png"))
