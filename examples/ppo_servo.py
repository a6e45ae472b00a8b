"""PPO from Stable-Baselines3 on the navigation and servo envs, on a CPU, out of the box.

The envs observe a ``Dict``; ``--obs`` picks what the policy sees:

- ``image`` (default): the camera image alone, 84 x 84 grayscale (``sim.wrappers.
  ImageObservation``; on a servo env the target's view beside it), for ``CnnPolicy``;
- ``vector``: the scan reduced to 36 beams and the odometry as one float32 vector
  (``sim.wrappers.ScanOdometryObservation``; the target's scan too on a servo env), for
  ``MlpPolicy``; the navigation env then renders no camera at all;
- ``dict``: every key, the images downscaled to 64 x 48, for ``MultiInputPolicy``.

Install the extra first (a CPU build of PyTorch is enough)::

    pip install -e ".[rl]"

Then, from any folder (``MUJOCO_GL=egl`` on a machine without a display)::

    python examples/ppo_servo.py --env topomap/Hallway-v0 --steps 2048
    python examples/ppo_servo.py --env topomap/HallwayServo-v0 --obs vector --map PATH

(``python -m examples.ppo_servo`` works from the repository's root.) ``--map``: the ``.json``
path of a saved servo map (``servo.save_map(m, directory)`` returns it); without it the
world's default map is loaded from the data home (built there the first time, which collects
the default dataset: minutes). A map goes to ``gym.make`` by its path, which keeps the env's
spec small and JSON.
"""

from __future__ import annotations

import argparse
import time

import cv2
import gymnasium as gym
import numpy as np
from gymnasium.wrappers import TransformObservation

import servo  # noqa: F401  (registers the servo envs)
import sim  # noqa: F401  (headless GL before mujoco; registers the navigation envs)
from sim.wrappers import ImageObservation, ScanOdometryObservation

IMAGE_SIZE = (48, 64)  # (height, width) the policy sees
IMAGE_KEYS = ("image", "target_image")
SERVO_STEPS = 200  # a servo episode's limit while training: several episodes in a short run
OBSERVATIONS = {"image": "CnnPolicy", "vector": "MlpPolicy", "dict": "MultiInputPolicy"}
CNN_SIZE = (84, 84)  # (height, width) of the grayscale image of --obs image


def downscale(env: gym.Env, size: tuple[int, int] = IMAGE_SIZE) -> gym.Env:
    """``env`` with its camera images (``IMAGE_KEYS``) resized to ``size`` (height, width) by
    area averaging; the other keys pass unchanged. Images already that size are left alone."""
    h, w = size
    spaces = dict(env.observation_space.spaces)
    keys = [k for k in IMAGE_KEYS if k in spaces and spaces[k].shape[:2] != (h, w)]
    if not keys:
        return env
    for k in keys:
        spaces[k] = gym.spaces.Box(0, 255, (h, w, 3), np.uint8)

    def resize(obs: dict) -> dict:
        return {
            k: cv2.resize(v, (w, h), interpolation=cv2.INTER_AREA) if k in keys else v
            for k, v in obs.items()
        }

    return TransformObservation(env, resize, gym.spaces.Dict(spaces))


def make_env(
    env_id: str, servo_map: str | None = None, size=IMAGE_SIZE, obs: str = "dict"
) -> gym.Env:
    """The env the policy trains on: ``env_id`` seen through ``obs`` (`OBSERVATIONS`). A
    servo id takes ``servo_map`` (a saved map's path, or None for the world's default map)
    and ends its episodes after ``SERVO_STEPS``. ``"dict"``: the images at ``size``, which a
    navigation id renders itself; ``"image"``: 84 x 84 grayscale; ``"vector"``: scan and
    odometry, the navigation id without its camera."""
    if obs not in OBSERVATIONS:
        raise ValueError(f"obs must be one of {tuple(OBSERVATIONS)}, got {obs!r}")
    servo_id = "Servo" in env_id
    if servo_id:
        env = gym.make(env_id, servo_map=servo_map, max_steps=SERVO_STEPS)
    elif obs == "vector":
        env = gym.make(env_id, sensors=("scan",))
    else:
        height, width = size if obs == "dict" else CNN_SIZE
        env = gym.make(env_id, camera={"width": width, "height": height})
    if obs == "image":
        keys = ("image", "target_image") if servo_id else ("image",)
        return ImageObservation(env, keys, size=CNN_SIZE, grayscale=True)
    if obs == "vector":
        return ScanOdometryObservation(env)
    return downscale(env, size)


def train(
    env_id: str,
    steps: int,
    servo_map: str | None = None,
    seed: int = 0,
    threads: int = 1,
    obs: str = "image",
    size=IMAGE_SIZE,
) -> dict:
    """PPO on `make_env` (the policy of ``obs`` in `OBSERVATIONS`, ``size`` the images of
    ``"dict"``) for ``steps`` env steps, PyTorch on ``threads`` threads; returns the steps,
    the wall time, the steps per second, the episodes ended and their mean reward."""
    import torch
    from stable_baselines3 import PPO  # the optional extra: pip install -e ".[rl]"

    # One thread: the small network gains little from more, and on a busy 2-core machine
    # PyTorch's default (a thread per core) ran 256 steps in 29 s instead of 2.3 s.
    torch.set_num_threads(threads)

    env = make_env(env_id, servo_map, size, obs=obs)
    model = PPO(OBSERVATIONS[obs], env, n_steps=256, batch_size=64, seed=seed, verbose=0)
    start = time.perf_counter()
    model.learn(total_timesteps=steps)
    seconds = time.perf_counter() - start
    rewards = [e["r"] for e in model.ep_info_buffer]
    env.close()
    return {
        "env": env_id,
        "obs": obs,
        "steps": model.num_timesteps,
        "seconds": round(seconds, 1),
        "steps_per_s": round(model.num_timesteps / seconds, 1),
        "episodes": len(rewards),
        "mean_episode_reward": float(np.mean(rewards)) if rewards else None,
    }


def main(argv=None) -> None:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--env", default="topomap/HallwayServo-v0", help="a topomap env id")
    p.add_argument("--steps", type=int, default=2048, help="env steps to train for")
    p.add_argument("--map", default=None, help="a saved servo map's .json path (servo ids)")
    p.add_argument("--seed", type=int, default=0)
    p.add_argument("--threads", type=int, default=1, help="PyTorch's threads")
    p.add_argument("--obs", choices=tuple(OBSERVATIONS), default="image",
                   help="what the policy sees (image: CnnPolicy; vector: MlpPolicy; dict: "
                   "MultiInputPolicy)")  # fmt: skip
    a = p.parse_args(argv)
    print(train(a.env, a.steps, a.map, a.seed, a.threads, a.obs))


if __name__ == "__main__":
    main()
