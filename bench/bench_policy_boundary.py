"""The cost of running a policy in its own process (``servo.task.remote.RemotePolicy``): the
same policy's ``act`` on the same observations, in this process and across the boundary,
interleaved in one run, with the env's own step for scale.

Run: ``.venv/bin/python bench/bench_policy_boundary.py [--steps N] [--sandbox]``. Records
the world's observations by driving ``examples.my_policy`` (cheap: the boundary is what is
timed), then times ``act`` on each both ways. Prints the machine's core count, the median ms
per step of each, the overhead (their difference; target: at most 2 ms) and the ratio of a
step's whole time (env step + act) across the boundary to in process. Uses a small map of a
generated world (``lawn:3``, 8 frames a drive) in a temporary folder: about 30 s.
"""

from __future__ import annotations

import argparse
import os
import platform
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

import sim  # noqa: F401  (headless GL before mujoco)

SPEC = "examples.my_policy:make_policy"
TARGET_MS = 2.0


def small_map(folder: Path):
    """A servo map of ``lawn:3`` from 8 frames a drive (the test suite's small map)."""
    from servo.maps import MapSettings, load_or_build
    from sim.collect import CollectionSettings, collect_dataset

    collect_dataset(
        folder / "data", CollectionSettings(worlds=("lawn:3",), frames=8), jobs=1, progress=False
    )
    settings = MapSettings(stride=1, min_cluster_size=3, image_size=(16, 12))
    return load_or_build("lawn:3", folder / "data", folder / "maps", settings, progress=False)


def measure(steps: int, sandbox: bool) -> dict:
    """Median ms per ``act`` in process and across the boundary, and per env step."""
    from servo.task import RemotePolicy, ServoEnv, Target, make_outside_policy

    with tempfile.TemporaryDirectory(prefix="bench-boundary-") as tmp:
        m = small_map(Path(tmp))
        env = ServoEnv("lawn:3", m, max_steps=steps)
        here = make_outside_policy(SPEC, m, np.random.default_rng(0))
        there = RemotePolicy(SPEC, m, sandbox=sandbox, hide=[tmp])
        try:
            obs, info = env.reset(seed=0)
            target = Target(int(info["target_view"]), m.images[int(info["target_view"])])
            here.reset(target)
            there.reset(target)
            t_here, t_there, t_env = [], [], []
            for _ in range(steps):
                t0 = time.perf_counter()
                action = here.act(obs)
                t1 = time.perf_counter()
                there.act(obs)
                t2 = time.perf_counter()
                obs, _, terminated, truncated, _ = env.step(np.asarray(action, np.float32))
                t3 = time.perf_counter()
                t_here.append(t1 - t0)
                t_there.append(t2 - t1)
                t_env.append(t3 - t2)
                if terminated or truncated:
                    obs, info = env.reset(seed=len(t_env))
        finally:
            there.close()
            env.close()
    here_ms, there_ms, env_ms = (1e3 * float(np.median(t)) for t in (t_here, t_there, t_env))
    ratio = (env_ms + there_ms) / (env_ms + here_ms)
    return {
        "steps": len(t_env),
        "in_process_ms": here_ms,
        "own_process_ms": there_ms,
        "overhead_ms": there_ms - here_ms,
        "env_step_ms": env_ms,
        "step_ratio": ratio,
        "sandboxed": sandbox,
    }


def main(argv=None) -> int:
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    p.add_argument("--steps", type=int, default=200)
    p.add_argument("--sandbox", action="store_true", help="the policy's process sandboxed")
    args = p.parse_args(argv)
    r = measure(args.steps, args.sandbox)
    print(
        f"cores (os.cpu_count): {os.cpu_count()}; {platform.platform()}; load "
        f"{os.getloadavg()[0]:.2f}; steps {r['steps']}; sandboxed {r['sandboxed']}"
    )
    print("| measure | median ms per step |\n|---|---|")
    for key in ("in_process_ms", "own_process_ms", "overhead_ms", "env_step_ms"):
        print(f"| {key} | {r[key]:.3f} |")
    met = "yes" if r["overhead_ms"] <= TARGET_MS else "no"
    print(
        f"\noverhead {r['overhead_ms']:.3f} ms (target <= {TARGET_MS} ms: {met}); a step's "
        f"whole time across the boundary / in process: {r['step_ratio']:.3f}"
    )
    return 0


if __name__ == "__main__":
    sys.exit(main())
