"""Speed of generated worlds beside the canonical ones, measured in the same run: building and
compiling a world (median over seeds), and simulator steps/s with camera and laser (a step,
a 320x240 frame and a scan, as an env step costs) on generated worlds as a ratio of the
canonical world's, and how that ratio goes with the number of stretches; and collecting one
world's dataset (``sim.collect``, its default settings: a teleop drive to every leaf) on the
machine's cores, for the largest of the first ``--collect`` generated worlds beside the
canonical one.

Run: ``.venv/bin/python bench/bench_worlds.py [--seeds 50] [--worlds 20] [--collect 5]``.
Prints a table with the machine's core count; the targets are for a 2-core CPU machine.
"""

from __future__ import annotations

import argparse
import os
import platform
import tempfile
import time

import mujoco
import numpy as np

import sim  # noqa: F401  (headless GL before mujoco)
from scenes import build_world
from scenes.families import split_worlds
from sim.camera import CameraConfig
from sim.laser import LaserConfig
from sim.simulator import Simulator


def build_seconds(name: str) -> float:
    """Seconds to build ``name`` and compile it into an MjModel."""
    start = time.perf_counter()
    world = build_world(name)
    mujoco.MjModel.from_xml_string(world.xml, world.assets)
    return time.perf_counter() - start


def sensor_steps_per_s(name: str, n: int = 150) -> float:
    """Steps/s of a step + camera frame + laser scan, driving the world's first route."""
    world = build_world(name)
    s = Simulator(world, CameraConfig(), LaserConfig(), control_dt=0.1)
    route = next(iter(world.routes.values())).waypoints
    heading = np.arctan2(*(route[1] - route[0])[::-1])
    s.reset((route[0][0], route[0][1], heading), np.random.default_rng(0))
    rng = np.random.default_rng(1)

    def step():
        s.step(0.3, 0.0)
        s.render()
        s.scan(rng)

    try:
        step()  # the first frame creates the renderer
        start = time.perf_counter()
        for _ in range(n):
            step()
        return n / (time.perf_counter() - start)
    finally:
        s.close()


def collect_seconds(name: str) -> float:
    """Seconds to collect ``name``'s dataset with the default settings, on every core."""
    from sim.collect import CollectionSettings, collect_dataset

    with tempfile.TemporaryDirectory(prefix="bench-collect-") as tmp:
        start = time.perf_counter()
        collect_dataset(tmp, CollectionSettings(worlds=(name,)), progress=False)
        return time.perf_counter() - start


def main(argv=None) -> None:
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    p.add_argument("--seeds", type=int, default=50, help="worlds per family for the build time")
    p.add_argument("--worlds", type=int, default=20, help="worlds per family for steps/s")
    p.add_argument(
        "--collect",
        type=int,
        default=5,
        help="worlds per family to pick the largest from for the dataset time",
    )
    args = p.parse_args(argv)
    print(
        f"machine: {platform.machine()}, cores: {os.cpu_count()}, "
        f"MUJOCO_GL={os.environ.get('MUJOCO_GL')}"
    )
    print(f"{'measure':58s} {'value':>8s}  target")
    for family in ("hallway", "lawn"):
        names = split_worlds(family, "train", args.seeds)
        build_seconds(names[0])  # imports and caches out of the timing
        times = [build_seconds(n) for n in names]
        print(
            f"{f'build + compile, {family}:1-{args.seeds} (median s)':58s} "
            f"{np.median(times):8.3f}  <= 0.5"
        )
        print(f"{f'build + compile, canonical {family} (s)':58s} {build_seconds(family):8.3f}")
        canonical = sensor_steps_per_s(family)
        rates, sizes = [], []
        for name in names[: args.worlds]:
            rates.append(sensor_steps_per_s(name))
            sizes.append(len(build_world(name).manifold_names))
        rates, sizes = np.asarray(rates), np.asarray(sizes)
        print(f"{f'camera + laser steps/s, canonical {family}':58s} {canonical:8.1f}")
        print(
            f"{f'  generated / canonical, median of {len(rates)} worlds':58s} "
            f"{np.median(rates) / canonical:8.2f}  >= 0.9"
        )
        for lo, hi in ((2, 4), (5, 8), (9, 12)):
            pick = (sizes >= lo) & (sizes <= hi)
            if pick.any():
                print(
                    f"{f'  {lo}-{hi} stretches ({pick.sum()} worlds)':58s} "
                    f"{np.median(rates[pick]) / canonical:8.2f}"
                )

        pool = names[: args.collect]
        largest = max(pool, key=lambda n: len(build_world(n).manifold_names))
        k = len(build_world(largest).manifold_names)
        print(f"{f'dataset, canonical {family} (s)':58s} {collect_seconds(family):8.1f}")
        print(
            f"{f'dataset, {largest} ({k} manifolds) (s)':58s} {collect_seconds(largest):8.1f}"
            "  <= 30"
        )


if __name__ == "__main__":
    main()
