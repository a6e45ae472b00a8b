"""The training example's env pipeline, smoked without PyTorch: the images downscaled, the
observations inside their spaces, and Gymnasium's flattening and normalising wrappers (what a
network's input layer sees) free of NaN; PPO itself where Stable-Baselines3 is installed."""

import numpy as np
import pytest
from gymnasium.wrappers import FlattenObservation, NormalizeObservation

from examples.ppo_servo import IMAGE_SIZE, make_env
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
    assert images and all(
        env.observation_space[k].shape == (*IMAGE_SIZE, 3) for k in images
    )
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


def test_ppo_trains_a_few_steps(lawn_map_path):
    """Where the optional extra is installed (pip install -e ".[rl]"); CI has no PyTorch."""
    pytest.importorskip("stable_baselines3")
    from examples.ppo_servo import train

    out = train("topomap/LawnServo-v0", 128, lawn_map_path)
    assert out["steps"] >= 128 and out["steps_per_s"] > 0
