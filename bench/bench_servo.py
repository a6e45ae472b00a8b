"""Speed of the servo controllers: one ``act`` (localise + decide) per env step of the
laser+image ``ManifoldServo`` (``policy="servo"``) and of the camera-only ``SignalServo``
(``policy="signal"``), the global localisation (the servo's step that ends its observing turn
and places the all-round scan on the map, once per episode and again when it is lost; the
signal controller localises while it turns in place, an ordinary step each, so its first step
is shown, and apart from the other steps the one that ends its turn: the global fix from the
turn's images, with ``fix_check`` the metric check of its candidates), the env step itself,
the map build and the controller's set-up (the servo's metric map: pose graph, point map,
free space).

Run: ``.venv/bin/python bench/bench_servo.py [--episodes N] [--policy servo signal]``. Prints
the machine's core count and a table; the targets are a controller step
within 10 ms median and the start-of-episode localisation within 0.5 s on a 2-core CPU machine.
"""

from __future__ import annotations

import argparse
import os
import platform
import time

import numpy as np

import servo  # noqa: F401  (headless GL before mujoco)
from servo.laser_image import ManifoldServo
from servo.maps import build_map, load_or_build
from servo.task import ServoEnv, make_policy
from sim.datahome import default_dataset


def bench_world(world: str, episodes: int, dataset=None, cache=None, policy: str = "servo") -> dict:
    """Time one world's map build, ``policy``'s controller steps and env steps; ``dataset``
    and ``cache`` default to the data home's (``sim.datahome``)."""
    dataset = default_dataset() if dataset is None else dataset
    start = time.perf_counter()
    build_map(dataset, world)  # timed; the cached copy below is what the env uses
    build_s = time.perf_counter() - start
    m = load_or_build(world, dataset, cache)
    env = ServoEnv(world, m)
    start = time.perf_counter()
    ctl = make_policy(policy, env, np.random.default_rng(0))
    init_s = time.perf_counter() - start
    first, plans, steps, env_steps = [], [], [], []
    try:
        for ep in range(episodes):
            obs, info = env.reset(seed=ep)
            ctl.reset(info["target_view"])
            for t in range(env.max_steps):
                before = getattr(ctl, "relocalisations_", None)
                observing = getattr(ctl, "phase_", None) == "observe"
                t0 = time.perf_counter()
                action = ctl.act(obs)
                dt = time.perf_counter() - t0
                fixed = before is not None and ctl.relocalisations_ > before
                # the step that ends an observing turn: the servo's global localisation
                # (its counter moves on that step), the signal controller's global fix
                planned = observing and ctl.phase_ != "observe"
                if fixed:
                    first.append(dt)
                elif planned:
                    plans.append(dt)
                else:
                    (first if before is None and t == 0 else steps).append(dt)
                t0 = time.perf_counter()
                obs, _, term, trunc, _ = env.step(action)
                env_steps.append(time.perf_counter() - t0)
                if term or trunc:
                    break
    finally:
        env.close()
    ms = 1e3 * np.asarray(steps)
    return {
        "world": world,
        "policy": policy,
        "steps": len(steps),
        "act median (ms)": np.median(ms),
        "act p95 (ms)": np.percentile(ms, 95),
        "act max (ms)": ms.max(),
        "global localisation (ms)": 1e3 * np.median(first),
        "global localisation max (ms)": 1e3 * np.max(first),
        "fix at the end of the turn, median / max (ms)": (
            f"{1e3 * np.median(plans):.0f} / {1e3 * np.max(plans):.0f}" if plans else "-"
        ),
        "env step (ms)": 1e3 * np.median(env_steps),
        "map build (s)": build_s,
        "controller set-up (s)": init_s,
    }


# Known limitation (docs/guides/servo.md): from the middle of the uniform straight branch, global
# localisation can start ~2 m off along it, more than a tracking correction may move, so the
# episode to the right branch fails on some machines and succeeds on others.
KNOWN_LIMITATION = ("hallway", "hallway-straight", "hallway-right", 11)


def known_limitation(dataset=None, cache=None) -> dict:
    """Run the known-limitation episode (start and target: the middle stored views of the two
    manifolds); returns its record."""
    from servo.task import run_episode

    world, start, target, seed = KNOWN_LIMITATION
    dataset = default_dataset() if dataset is None else dataset
    m = load_or_build(world, dataset, cache)

    def middle(name):
        views = np.flatnonzero(m.true_labels == m.manifold_names.index(name))
        return int(views[len(views) // 2])

    env = ServoEnv(world, m, max_steps=500)
    try:
        options = {"start_view": middle(start), "target": middle(target)}
        return run_episode(env, ManifoldServo(m, world=world), seed, options)
    finally:
        env.close()


def main() -> None:
    p = argparse.ArgumentParser(description=__doc__)
    p.add_argument("--episodes", type=int, default=5)
    p.add_argument("--policy", nargs="+", default=["servo", "signal"], choices=["servo", "signal"])
    args = p.parse_args()
    print(f"machine: {platform.processor() or platform.machine()}, {os.cpu_count()} cores")
    rows = [
        bench_world(w, args.episodes, policy=pol)
        for pol in args.policy
        for w in ("hallway", "lawn")
    ]
    keys = list(rows[0])
    print(" | ".join(keys))
    for r in rows:
        print(" | ".join(f"{r[k]:.2f}" if isinstance(r[k], float) else str(r[k]) for k in keys))
    r = known_limitation()
    print(
        f"known limitation {KNOWN_LIMITATION[1]} -> {KNOWN_LIMITATION[2]}: {r['reason']}, "
        f"final distance {r['final_distance']:.2f} m"
    )


if __name__ == "__main__":
    main()
