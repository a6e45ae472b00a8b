"""The observation wrappers: one ``Box`` each, on the navigation and servo envs, inside its
space and finite, taken by Gymnasium's image and normalising wrappers without options, and by
Stable-Baselines3's policies where the optional extra is installed."""

import gymnasium as gym
import numpy as np
import pytest
from gymnasium.wrappers import (
    FrameStackObservation,
    GrayscaleObservation,
    NormalizeObservation,
    ResizeObservation,
)

import servo  # noqa: F401  (registers the servo ids)
from servo.maps.file import save_map
from sim.wrappers import ImageObservation, ScanObservation, ScanOdometryObservation


@pytest.fixture(scope="module")
def servo_env_args(generated_servo_map, tmp_path_factory):
    path = save_map(generated_servo_map[0], tmp_path_factory.mktemp("map"))
    return {"world": "lawn:3", "servo_map": str(path), "max_steps": 20}


def _navigation():
    return gym.make("topomap/Lawn-v0", camera={"width": 160, "height": 120})


def _servo(args):
    return gym.make("topomap/LawnServo-v0", **args)


def _run(env, steps=12):
    env.action_space.seed(0)
    obs, _ = env.reset(seed=0)
    for _ in range(steps):
        assert env.observation_space.contains(obs) and np.isfinite(obs).all()
        obs, _, terminated, truncated, _ = env.step(env.action_space.sample())
        if terminated or truncated:
            obs, _ = env.reset()
    env.close()
    return obs


@pytest.mark.parametrize("grayscale", [False, True])
def test_the_image_alone_resized(grayscale):
    env = ImageObservation(_navigation(), size=(84, 84), grayscale=grayscale)
    assert env.observation_space.shape == (84, 84, 1 if grayscale else 3)
    assert _run(env).dtype == np.uint8


def test_the_image_at_the_camera_size_is_the_camera_image():
    env = ImageObservation(_navigation())
    obs, _ = env.reset(seed=3)
    assert np.array_equal(obs, env.unwrapped._observe()["image"])
    env.close()


def test_the_servo_env_images_side_by_side(servo_env_args):
    env = ImageObservation(_servo(servo_env_args), ("image", "target_image"), (48, 64), True)
    assert env.observation_space.shape == (48, 128, 1)
    _run(env)


@pytest.mark.parametrize("beams", [None, 36])
def test_the_scan_alone(beams):
    env = ScanObservation(gym.make("topomap/Lawn-v0", sensors=("scan",)), beams=beams)
    assert env.observation_space.shape == ((361,) if beams is None else (36,))
    obs = _run(env)
    assert obs.dtype == np.float32 and obs.max() <= 20.0


def test_a_group_of_beams_reads_its_nearest_range():
    env = ScanObservation(gym.make("topomap/Lawn-v0", sensors=("scan",)), beams=19)
    raw, _ = env.env.reset(seed=2)
    starts = np.linspace(0, 361, 19, endpoint=False).astype(int)
    groups = np.split(raw["scan"], starts[1:])
    assert np.array_equal(env.observation(raw), [g.min() for g in groups])
    env.close()


def test_scan_and_odometry_on_both_envs(servo_env_args):
    nav = ScanOdometryObservation(gym.make("topomap/Lawn-v0", sensors=("scan",)))
    assert nav.observation_space.shape == (40,) and nav.keys == ("scan",)
    obs, _ = nav.reset(seed=0)
    assert np.allclose(obs[-4:], [0.0, 0.0, 1.0, 0.0], atol=1e-9)
    for _ in range(10):
        obs, *_ = nav.step(np.array([1.0, 0.0], np.float32))
    assert obs[-4] > 0.5 and 0.0 <= obs[:-4].min() and obs[:-4].max() <= 1.0  # 1 m ahead
    nav.close()
    env = ScanOdometryObservation(_servo(servo_env_args), beams=24)
    assert env.observation_space.shape == (52,) and env.keys == ("scan", "target_scan")
    _run(env)


def test_gymnasium_wrappers_take_them_without_options(servo_env_args):
    colour = ImageObservation(_navigation())
    _run(
        FrameStackObservation(
            NormalizeObservation(GrayscaleObservation(ResizeObservation(colour, (42, 42)))), 4
        ),
        steps=4,
    )
    gray = ImageObservation(_navigation(), size=(84, 84), grayscale=True)
    _run(FrameStackObservation(NormalizeObservation(ResizeObservation(gray, (42, 42))), 4), 4)
    for wrapped in (
        ScanObservation(gym.make("topomap/Lawn-v0", sensors=("scan",)), 36),
        ScanOdometryObservation(_servo(servo_env_args)),
    ):
        _run(FrameStackObservation(NormalizeObservation(wrapped), 4), steps=4)


def test_the_arguments_are_checked():
    scan_only = gym.make("topomap/Lawn-v0", sensors=("scan",))
    with pytest.raises(ValueError, match=r"needs the observation keys \['image'\]"):
        ImageObservation(scan_only)
    camera = gym.make("topomap/Lawn-v0", sensors=("image",))
    with pytest.raises(ValueError, match="keys must be a non-empty tuple"):
        ImageObservation(camera, keys="image")
    with pytest.raises(ValueError, match="size must be"):
        ImageObservation(camera, size=84)
    with pytest.raises(ValueError, match="grayscale must be True or False"):
        ImageObservation(camera, grayscale="yes")
    with pytest.raises(ValueError, match="needs the observation keys"):
        ScanObservation(camera)
    with pytest.raises(ValueError, match="at most the laser's 361 beams"):
        ScanObservation(scan_only, beams=400)
    with pytest.raises(ValueError, match="beams must be an integer"):
        ScanOdometryObservation(scan_only, beams=2.5)
    with pytest.raises(ValueError, match="no_return='max_range'"):
        ScanObservation(gym.make("topomap/Lawn-v0", sensors=("scan",), no_return="inf"))
    with pytest.raises(TypeError, match="Dict observation"):
        ScanObservation(ScanObservation(scan_only))


def test_stable_baselines3_policies_take_them():
    """Where the optional extra is installed (pip install -e ".[rl]")."""
    pytest.importorskip("stable_baselines3")
    import torch
    from stable_baselines3 import PPO
    from stable_baselines3.common.env_checker import check_env
    from stable_baselines3.common.vec_env import DummyVecEnv, VecNormalize

    torch.set_num_threads(1)
    image = ImageObservation(_navigation(), size=(84, 84), grayscale=True)
    check_env(image)
    PPO("CnnPolicy", image, n_steps=32, batch_size=32, n_epochs=1, seed=0).learn(32)
    vector = VecNormalize(
        DummyVecEnv(
            [lambda: ScanOdometryObservation(gym.make("topomap/Lawn-v0", sensors=("scan",)))]
        )
    )
    PPO("MlpPolicy", vector, n_steps=32, batch_size=32, n_epochs=1, seed=0).learn(32)
    assert np.isfinite(vector.obs_rms.mean).all()
