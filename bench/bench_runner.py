"""The servo runner's own time per step, beside the env step: what ``run_episode`` adds to a
policy's ``act`` and the env's ``step`` (the guard around the call with its alarm, the action's
check, the info's copy, the true geodesic distance it records), with no F logging (the policy
has no waypoint view) and no video.

Run: ``.venv/bin/python bench/bench_runner.py [--episodes N] [--world hallway] [--data DIR]
[--maps DIR]``. Prints the
machine's core count and the medians; the target is a runner overhead within 1 ms median.
"""

from __future__ import annotations

import argparse
import os
import platform
import time

import numpy as np

import servo  # noqa: F401  (headless GL before mujoco)
from servo.maps import load_or_build
from servo.task import ServoEnv, run_episode
from sim.datahome import default_dataset

ACTION = np.array([0.4, 0.3], np.float32)  # a slow circle: long episodes, few collisions


class _TimedEnv:
    """``env`` with the start and end of every ``step`` recorded."""

    def __init__(self, env: ServoEnv):
        self.env, self.steps = env, []

    def __getattr__(self, name):
        return getattr(self.env, name)

    def step(self, action):
        t0 = time.perf_counter()
        out = self.env.step(action)
        self.steps.append((t0, time.perf_counter()))
        return out


class _TimedPolicy:
    """A constant command, the start and end of every ``act`` recorded."""

    def __init__(self):
        self.acts = []

    def reset(self, target) -> None:
        pass

    def act(self, observation) -> np.ndarray:
        t0 = time.perf_counter()
        self.acts.append((t0, time.perf_counter()))
        return ACTION


def runner_overhead(
    world: str = "hallway", episodes: int = 3, max_steps: int = 200, dataset=None, cache=None
) -> dict:
    """Median seconds per step of the runner's own work and of the env's step, over
    ``episodes`` episodes of ``world`` (``dataset`` and ``cache``: the data home's by
    default)."""
    dataset = default_dataset() if dataset is None else dataset
    env = ServoEnv(world, load_or_build(world, dataset, cache), max_steps=max_steps)
    overhead, env_step = [], []
    try:
        for ep in range(episodes):
            timed, policy = _TimedEnv(env), _TimedPolicy()
            run_episode(timed, policy, seed=ep)
            acts, steps = policy.acts, timed.steps
            # step i: from the end of act i to the start of step i, and from the end of
            # step i to the start of act i + 1
            for i in range(len(steps) - 1):
                overhead.append(steps[i][0] - acts[i][1] + acts[i + 1][0] - steps[i][1])
            env_step += [b - a for a, b in steps]
    finally:
        env.close()
    return {
        "world": world,
        "steps": len(overhead),
        "runner_ms": 1e3 * float(np.median(overhead)),
        "runner_p95_ms": 1e3 * float(np.percentile(overhead, 95)),
        "env_step_ms": 1e3 * float(np.median(env_step)),
    }


def main() -> None:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--episodes", type=int, default=3)
    p.add_argument("--world", default="hallway", choices=["hallway", "lawn"])
    p.add_argument("--data", default=None, help="dataset folder (default: the data home's)")
    p.add_argument("--maps", default=None, help="servo map cache (default: the data home's)")
    args = p.parse_args()
    print(
        f"machine: {platform.processor() or platform.machine()}, {os.cpu_count()} cores, "
        f"load {os.getloadavg()[0]:.1f}"
    )
    r = runner_overhead(args.world, args.episodes, dataset=args.data, cache=args.maps)
    print(
        f"{r['world']}: runner {r['runner_ms']:.3f} ms median ({r['runner_p95_ms']:.3f} ms "
        f"95th percentile) per step over {r['steps']} steps, beside the env step "
        f"{r['env_step_ms']:.2f} ms median (target: runner <= 1 ms median)"
    )


if __name__ == "__main__":
    main()
