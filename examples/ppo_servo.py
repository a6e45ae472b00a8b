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

``--curve FILE.png`` draws the learning curve (mean episode reward; the success rate on a
servo id or the share of episodes without a collision on a navigation id; the metres driven
per episode; against the steps) and writes its numbers beside it (``FILE.json``).

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
    """Wrap ``env`` so that its camera images are resized to ``size`` (height, width).

    The images (``IMAGE_KEYS``) are resized by area averaging; the other keys pass unchanged.
    Images already that size are left alone.
    """
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
    """Make the env the policy trains on: ``env_id`` seen through ``obs`` (`OBSERVATIONS`).

    A servo id takes ``servo_map`` (a saved map's path, or None for the world's default map)
    and ends its episodes after ``SERVO_STEPS``. ``"dict"``: the images at ``size``, which a
    navigation id renders itself; ``"image"``: 84 x 84 grayscale; ``"vector"``: scan and
    odometry, the navigation id without its camera.
    """
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


def episode_outcome(info: dict, episode_return: float) -> tuple[float, bool]:
    """Return one ended episode as the curve counts it: its return and whether it went well.

    A servo episode went well if it reached its target; a navigation episode, which never
    terminates, if it hit nothing.
    """
    if "success" in info:
        return float(episode_return), bool(info["success"])
    return float(episode_return), episode_return == 0.0  # its only reward: the collisions


def train(
    env_id: str,
    steps: int,
    servo_map: str | None = None,
    seed: int = 0,
    threads: int = 1,
    obs: str = "image",
    size=IMAGE_SIZE,
) -> dict:
    """Train PPO on `make_env` and return its timing and episodes.

    PPO (the policy of ``obs`` in `OBSERVATIONS`, ``size`` the images of ``"dict"``) runs for
    ``steps`` env steps, PyTorch on ``threads`` threads; returns the steps, the wall time, the
    steps per second, the episodes ended, their mean reward and ``episodes_detail``: each ended
    episode's step count, return, outcome (`episode_outcome`) and the metres the robot drove
    in it.
    """
    import torch
    from stable_baselines3 import PPO  # the optional extra: pip install -e ".[rl]"
    from stable_baselines3.common.callbacks import BaseCallback

    class Episodes(BaseCallback):
        def __init__(self):
            super().__init__()
            self.ended, self.metres, self.last = [], {}, {}

        def _on_step(self) -> bool:
            for i, (done, info) in enumerate(
                zip(self.locals["dones"], self.locals["infos"], strict=True)
            ):
                # the distance driven: whether the robot learned to drive, or only to stop
                pose = np.asarray(info["pose"][:2], float) if "pose" in info else None
                if pose is not None and self.last.get(i) is not None:
                    self.metres[i] = self.metres.get(i, 0.0) + float(
                        np.hypot(*(pose - self.last[i]))
                    )
                self.last[i] = None if done else pose
                if done and "episode" in info:  # Monitor's summary of the ended episode
                    r, ok = episode_outcome(info, info["episode"]["r"])
                    metres = round(self.metres.pop(i, 0.0), 2)
                    self.ended.append(
                        {"step": int(self.num_timesteps), "return": r, "ok": ok, "metres": metres}
                    )
            return True

    # One thread: the small network gains little from more, and on a busy 2-core machine
    # PyTorch's default (a thread per core) ran 256 steps in 29 s instead of 2.3 s.
    torch.set_num_threads(threads)

    env = make_env(env_id, servo_map, size, obs=obs)
    model = PPO(OBSERVATIONS[obs], env, n_steps=256, batch_size=64, seed=seed, verbose=0)
    start = time.perf_counter()
    episodes = Episodes()
    model.learn(total_timesteps=steps, callback=episodes)
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
        "episodes_detail": episodes.ended,
    }


def plot_curve(result: dict, path: str, window: int = 10) -> None:
    """Plot the learning curve of a `train` result as a PNG at ``path``.

    It shows the mean return, the share of episodes that went well (`episode_outcome`) and
    the metres driven, over the last ``window`` ended episodes, against the env steps; its
    numbers go to the same name with ``.json``.
    """
    import json
    from pathlib import Path

    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    ended = result["episodes_detail"]
    if not ended:
        raise ValueError(f"no episode ended in {result['steps']} steps: nothing to plot")
    steps = np.array([e["step"] for e in ended])
    kernel = np.ones(min(window, len(ended)))

    def rolling(values):
        return np.convolve(values, kernel, "valid") / len(kernel)

    returns = rolling([e["return"] for e in ended])
    ok = rolling([float(e["ok"]) for e in ended])
    metres = rolling([e.get("metres", np.nan) for e in ended])
    x = steps[len(kernel) - 1 :]
    servo_id = "Servo" in result["env"]
    fig, (top, middle, bottom) = plt.subplots(3, 1, figsize=(6, 6.5), sharex=True)
    top.plot(x, returns)
    top.set_ylabel(f"mean return, last {len(kernel)}")
    middle.plot(x, ok)
    middle.set_ylim(-0.05, 1.05)
    middle.set_ylabel("success rate" if servo_id else "share without\na collision")
    bottom.plot(x, metres)
    bottom.set_ylim(bottom=0)
    bottom.set_ylabel("metres driven\nper episode")
    bottom.set_xlabel("env steps")
    top.set_title(f"PPO on {result['env']}, --obs {result['obs']}", fontsize=10)
    fig.tight_layout()
    out = Path(path)
    out.parent.mkdir(parents=True, exist_ok=True)
    tmp = out.with_name(f".{out.stem}.tmp.png")
    fig.savefig(tmp, dpi=100)
    plt.close(fig)
    tmp.replace(out)
    numbers = out.with_suffix(".json")
    tmp = numbers.with_name(f".{numbers.name}.tmp")
    tmp.write_text(json.dumps(result, indent=1))
    tmp.replace(numbers)


def main(argv=None) -> None:
    """Train PPO on a topomap env from the command line."""
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--env", default="topomap/HallwayServo-v0", help="a topomap env id")
    p.add_argument("--steps", type=int, default=2048, help="env steps to train for")
    p.add_argument("--map", default=None, help="a saved servo map's .json path (servo ids)")
    p.add_argument("--seed", type=int, default=0)
    p.add_argument("--threads", type=int, default=1, help="PyTorch's threads")
    p.add_argument(
        "--obs",
        choices=tuple(OBSERVATIONS),
        default="image",
        help="what the policy sees (image: CnnPolicy; vector: MlpPolicy; dict: MultiInputPolicy)",
    )
    p.add_argument(
        "--curve",
        default=None,
        metavar="FILE.png",
        help="draw the learning curve there (its numbers beside it, .json)",
    )
    a = p.parse_args(argv)
    result = train(a.env, a.steps, a.map, a.seed, a.threads, a.obs)
    if a.curve:
        plot_curve(result, a.curve)
    print({k: v for k, v in result.items() if k != "episodes_detail"})


if __name__ == "__main__":
    main()
