"""PPO from Stable-Baselines3 on the navigation and servo envs, on a CPU, out of the box.

The envs' observations are finite and inside their declared spaces (a laser beam with no
return reads the laser's maximum range, flagged by ``scan_valid``), so Stable-Baselines3's
``MultiInputPolicy`` takes them as they are. The one change this example makes is speed: the
camera images are downscaled (to 64 x 48 by default) before the network sees them. The
navigation env renders them that small itself (``camera={"width": 64, "height": 48}``); the
servo env's camera must match its map's views (320 x 240), so a Gymnasium
``TransformObservation`` resizes ``image`` and ``target_image``.

Install the extra first (a CPU build of PyTorch is enough)::

    pip install -e ".[rl]"

Run from the repository root, ``MUJOCO_GL=egl`` on a machine without a display::

    python -m examples.ppo_servo --env topomap/Hallway-v0 --steps 2048
    python -m examples.ppo_servo --env topomap/HallwayServo-v0 --steps 2048 --map PATH

``--map``: the ``.json`` path of a saved servo map (``servo.save_map(m, directory)`` returns
it); without it the world's default map is loaded from the data home (built there the first
time, which collects the default dataset: minutes). A map goes to ``gym.make`` by its path,
which keeps the env's spec small and JSON.
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

IMAGE_SIZE = (48, 64)  # (height, width) the policy sees
IMAGE_KEYS = ("image", "target_image")
SERVO_STEPS = 200  # a servo episode's limit while training: several episodes in a short run


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


def make_env(env_id: str, servo_map: str | None = None, size=IMAGE_SIZE) -> gym.Env:
    """The env the policy trains on: ``env_id`` with its images at ``size``. A navigation id
    renders at ``size``; a servo id takes ``servo_map`` (a saved map's path, or None for the
    world's default map), ends its episodes after ``SERVO_STEPS`` and is resized."""
    if "Servo" in env_id:
        env = gym.make(env_id, servo_map=servo_map, max_steps=SERVO_STEPS)
    else:
        env = gym.make(env_id, camera={"width": size[1], "height": size[0]})
    return downscale(env, size)


def train(
    env_id: str, steps: int, servo_map: str | None = None, seed: int = 0, threads: int = 1
) -> dict:
    """PPO (``MultiInputPolicy``) on `make_env` for ``steps`` env steps, PyTorch on
    ``threads`` threads; returns the steps, the wall time, the steps per second, the episodes
    ended and their mean reward."""
    import torch
    from stable_baselines3 import PPO  # the optional extra: pip install -e ".[rl]"

    # One thread: the small network gains little from more, and on a busy 2-core machine
    # PyTorch's default (a thread per core) ran 256 steps in 29 s instead of 2.3 s.
    torch.set_num_threads(threads)

    env = make_env(env_id, servo_map)
    model = PPO("MultiInputPolicy", env, n_steps=256, batch_size=64, seed=seed, verbose=0)
    start = time.perf_counter()
    model.learn(total_timesteps=steps)
    seconds = time.perf_counter() - start
    rewards = [e["r"] for e in model.ep_info_buffer]
    env.close()
    return {
        "env": env_id,
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
    a = p.parse_args(argv)
    print(train(a.env, a.steps, a.map, a.seed, a.threads))


if __name__ == "__main__":
    main()
