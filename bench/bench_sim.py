"""Speed of the simulator: env steps/s with and without the camera, camera frames/s at 320x240,
laser scans/s, and the wall time to collect the default 900-frame dataset; the registered envs'
steps/s under random actions as Gymnasium measures them (``gym_steps_per_s``).

Run: ``.venv/bin/python bench/bench_sim.py [--skip-dataset]``. Prints a table with the machine's
core count; the targets are for a 2-core CPU machine.
"""

from __future__ import annotations

import argparse
import os
import platform
import tempfile
import time

import gymnasium as gym
import numpy as np

import servo  # noqa: F401  (registers the servo envs)
import sim  # noqa: F401  (headless GL before mujoco)
from scenes import build_world
from sim.camera import CameraConfig
from sim.collect import CollectionSettings, collect_dataset
from sim.env import NavigationEnv
from sim.laser import LaserConfig
from sim.simulator import Simulator


def _rate(fn, n: int) -> float:
    fn()  # warm-up (first frame creates the renderer)
    start = time.perf_counter()
    for _ in range(n):
        fn()
    return n / (time.perf_counter() - start)


def env_steps_per_s(world: str, sensors: tuple[str, ...], n: int = 300) -> float:
    env = NavigationEnv(world, sensors=sensors)
    env.reset(seed=0, options={"pose": (2.0, 0.0, 0.0)})
    action = np.array([0.5, 0.05], np.float32)
    try:
        return _rate(lambda: env.step(action), n)
    finally:
        env.close()


def camera_fps(world: str, n: int = 300) -> float:
    s = Simulator(build_world(world), CameraConfig(), None)
    s.reset((2.0, 0.0, 0.0), np.random.default_rng(0))
    try:
        return _rate(s.render, n)
    finally:
        s.close()


def scans_per_s(world: str, n: int = 3000) -> float:
    s = Simulator(build_world(world), None, LaserConfig())
    s.reset((2.0, 0.0, 0.0), np.random.default_rng(0))
    rng = np.random.default_rng(1)
    return _rate(lambda: s.scan(rng), n)


def gym_steps_per_s(env_id: str, seconds: float = 5.0, **kwargs) -> float:
    """Steps/s of ``gym.make(env_id, **kwargs)`` under random actions, resets included, by
    Gymnasium's own ``gymnasium.utils.performance.benchmark_step`` (what an RL library's
    rollouts cost; the wrappers ``gym.make`` adds are timed too)."""
    from gymnasium.utils.performance import benchmark_step

    env = gym.make(env_id, **kwargs)
    try:
        return benchmark_step(env, target_duration=seconds, seed=0)
    finally:
        env.close()


def dataset_seconds() -> float:
    with tempfile.TemporaryDirectory() as tmp:
        start = time.perf_counter()
        collect_dataset(tmp, CollectionSettings(), progress=False)
        return time.perf_counter() - start


def main() -> None:
    p = argparse.ArgumentParser(description=__doc__)
    p.add_argument("--skip-dataset", action="store_true")
    args = p.parse_args()
    rows = []
    for world in ("hallway", "lawn"):
        target = ">= 150" if world == "hallway" else ""
        rows.append(
            (
                f"env steps/s, camera + laser, {world}",
                env_steps_per_s(world, ("image", "scan")),
                target,
            )
        )
        rows.append((f"env steps/s, laser only, {world}", env_steps_per_s(world, ("scan",)), ""))
        rows.append((f"camera frames/s 320x240, {world}", camera_fps(world), ""))
        rows.append((f"laser scans/s (361 beams), {world}", scans_per_s(world), ">= 3000"))
    if not args.skip_dataset:
        rows.append(("default dataset, 900 frames (s)", dataset_seconds(), "<= 30"))
    print(
        f"machine: {platform.machine()} {platform.processor() or ''}, cores: {os.cpu_count()}, "
        f"MUJOCO_GL={os.environ.get('MUJOCO_GL')}"
    )
    print(f"{'measure':45s} {'value':>10s}  target")
    for name, value, target in rows:
        print(f"{name:45s} {value:10.1f}  {target}")


if __name__ == "__main__":
    main()
