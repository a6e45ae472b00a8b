"""Speed of the reinforcement-learning pipelines of ``examples/ppo_servo.py``: for each
observation (``raw``: the env's own ``Dict``, images at 320 x 240, ``MultiInputPolicy``;
``dict``: the same, images at 64 x 48; ``image``: 84 x 84 grayscale, ``CnnPolicy``;
``vector``: scan and odometry, ``MlpPolicy``) the env's steps per second under random actions
and PPO's, each with its ratio to the ``raw`` pipeline measured in the same run, and the
machine's core count.

Run (the optional extra rl installed): ``python bench/bench_rl.py [--env ID] [--steps N]
[--map PATH] [--json]``. A servo id needs ``--map`` (a saved map's ``.json``), or builds the
world's default map in the data home first. The ratios, not the rates, are what compare across
machines: every pipeline runs on the same machine under the same load, one after the other.
"""

from __future__ import annotations

import argparse
import json
import os
import sys
import time
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))  # the examples by name

from common.cores import available_cores
from examples.ppo_servo import IMAGE_SIZE, OBSERVATIONS, make_env, train

# name: (the example's --obs, the dict pipeline's image size)
PIPELINES = {
    "raw": ("dict", (240, 320)),
    "dict": ("dict", IMAGE_SIZE),
    "image": ("image", IMAGE_SIZE),
    "vector": ("vector", IMAGE_SIZE),
}


def env_steps_per_s(env_id: str, pipeline: str, servo_map: str | None, seconds: float) -> float:
    """Steps per second of the wrapped env under random actions, resets included."""
    obs, size = PIPELINES[pipeline]
    env = make_env(env_id, servo_map, size, obs=obs)
    env.action_space.seed(0)
    env.reset(seed=0)
    steps, start = 0, time.perf_counter()
    while time.perf_counter() - start < seconds:
        _, _, terminated, truncated, _ = env.step(env.action_space.sample())
        steps += 1
        if terminated or truncated:
            env.reset()
    rate = steps / (time.perf_counter() - start)
    env.close()
    return rate


def measure(env_id: str, steps: int, servo_map: str | None, seconds: float) -> dict:
    """Every pipeline's env and PPO steps per second, with their ratios to ``raw``'s."""
    rows = {}
    for name, (obs, size) in PIPELINES.items():
        rows[name] = {
            "env_steps_per_s": env_steps_per_s(env_id, name, servo_map, seconds),
            "ppo_steps_per_s": train(env_id, steps, servo_map, obs=obs, size=size)["steps_per_s"],
        }
    for row in rows.values():
        for key in ("env_steps_per_s", "ppo_steps_per_s"):
            row[key.replace("steps_per_s", "ratio_to_raw")] = row[key] / rows["raw"][key]
    return {
        "env": env_id,
        "ppo_steps": steps,
        "cores": available_cores(),
        "load_1min": os.getloadavg()[0] if hasattr(os, "getloadavg") else None,
        "pipelines": rows,
    }


def markdown(result: dict) -> str:
    lines = [
        f"{result['env']}, {result['cores']} cores, load {result['load_1min']:.1f}, "
        f"PPO {result['ppo_steps']} steps",
        "",
        "| observation | policy | env steps/s | ratio | PPO steps/s | ratio |",
        "|---|---|---|---|---|---|",
    ]
    for name, row in result["pipelines"].items():
        lines.append(
            f"| {name} | {OBSERVATIONS[PIPELINES[name][0]]} | {row['env_steps_per_s']:.0f} | "
            f"{row['env_ratio_to_raw']:.2f} | {row['ppo_steps_per_s']:.0f} | "
            f"{row['ppo_ratio_to_raw']:.2f} |"
        )
    return "\n".join(lines)


def main(argv=None) -> None:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--env", default="topomap/Hallway-v0", help="a topomap env id")
    p.add_argument("--steps", type=int, default=512, help="PPO steps per pipeline")
    p.add_argument("--seconds", type=float, default=5.0, help="env timing per pipeline")
    p.add_argument("--map", default=None, help="a saved servo map's .json path (servo ids)")
    p.add_argument("--json", action="store_true", help="print the JSON instead of the table")
    a = p.parse_args(argv)
    result = measure(a.env, a.steps, a.map, a.seconds)
    print(json.dumps(result, indent=2) if a.json else markdown(result))


if __name__ == "__main__":
    main()
