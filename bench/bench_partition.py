"""Benchmark of the laser observation grouping (Blanco et al.).

    .venv/bin/python bench/bench_partition.py                # cost against n (the table)
    .venv/bin/python bench/bench_partition.py --targets      # the speed targets
    .venv/bin/python bench/bench_partition.py --targets --carmen LOG ...  # other real logs
    .venv/bin/python bench/bench_partition.py --incremental  # partial_fit per scan at 1000

All data are synthetic scans of ``mapping.grouping.office_world``: a corridor with
rooms, a route touring every room, a 181-beam 180-degree laser with 8 m range. The office of
the paper (4 rooms, 77 scans, one every 1.17 m) is scaled up by adding rooms. The
association, noise and figure studies are ``python -m experiments.grouping.partition_studies``.
``--targets`` also times real Carmen logs: those given by ``--carmen``, else the two Radish logs
in the folder ``TOPOMAP_RADISH`` names (``sim.datahome.radish_log``).
"""

from __future__ import annotations

import argparse
import os
import time
from pathlib import Path

import numpy as np

from mapping.grouping import (
    ObservationGraphPartitioner,
    office_path,
    office_world,
    raycast,
    recursive_ncut_partition,
    sensed_space_overlap,
)
from mapping.metrics import adjusted_rand_index, purity
from sim.datahome import RADISH_LOGS, RADISH_VAR, DataHomeError, radish_log

STEP = 1.17  # metres between scans: 77 scans in the paper-sized office
DENSE_STEP = 0.5  # a denser keyframe rate, for the stress row
DELTA = 0.1
# The dense synthetic log of the speed targets: 360 beams every 9 cm along a tour of a
# 20-room office (120 m of corridor), ~5000 scans, 8 m range.
DENSE_LOG = {"n_rooms": 20, "step": 0.09, "n_beams": 360}
IMG = Path(__file__).resolve().parents[1] / "docs" / "img"


def office_data(n_rooms: int, step: float, seed: int = 0):
    world = office_world(n_rooms=n_rooms)
    poses = office_path(world, step=step)
    scans = raycast(world.segments, poses, range_noise=0.01, rng=np.random.default_rng(seed))
    return world, scans, poses


def _best_of(fn, repeats: int) -> float:
    times = []
    for _ in range(repeats):
        t0 = time.perf_counter()
        fn()
        times.append(time.perf_counter() - t0)
    return min(times)


def bench_cost() -> None:
    print(f"os.cpu_count() = {os.cpu_count()}, load average = {os.getloadavg()}")
    print("best of repeats, wall-clock seconds; fit = overlap + partition + local maps + topology")
    header = f"{'rooms':>5} {'step':>5} {'scans':>6} {'points':>8} {'overlap':>8} {'partition':>9}"
    print(header + f" {'fit':>7} {'groups':>6} {'purity':>6}")
    rows = [(4, STEP), (12, STEP), (26, STEP), (52, STEP), (104, STEP), (50, DENSE_STEP)]
    for n_rooms, step in rows:
        _bench_row(n_rooms, step)


def _bench_row(n_rooms: int, step: float) -> None:
    world, scans, poses = office_data(n_rooms, step)
    repeats = 15 if len(scans) < 300 else 2
    # the overlap as the fit computes it (voxel grid of delta / 4, voxel_size="auto")
    W = sensed_space_overlap(scans, poses, DELTA, sparse=True, voxel_size=DELTA / 4)
    t_overlap = _best_of(
        lambda: sensed_space_overlap(scans, poses, DELTA, sparse=True, voxel_size=DELTA / 4),
        repeats,
    )
    t_part = _best_of(lambda: recursive_ncut_partition(W), repeats)
    # Given poses, as in the paper's timing (no ICP).
    model = ObservationGraphPartitioner(match_distance=DELTA, scan_matching=False)
    t_fit = _best_of(lambda: model.fit(scans, poses), repeats)
    pur = purity(world.region_labels(poses), model.labels_)
    print(
        f"{n_rooms:>5} {step:>5.2f} {len(scans):>6} {sum(map(len, scans)):>8} "
        f"{t_overlap:>8.3f} {t_part:>9.3f} {t_fit:>7.3f} {model.n_groups_:>6} {pur:>6.3f}"
    )


def bench_targets(logs: list[Path], repeats: int = 5) -> None:
    """The grouping's speed targets, each beside its peer measured in the same run: the real
    logs and the dense synthetic log with given poses and ICP off (voxel overlap, the default;
    the exact overlap, ``voxel_size=None``, beside it), and ICP on over ICP off."""
    from scripts.grouping import log_points
    from sim.readers import read_carmen

    print(f"os.cpu_count() = {os.cpu_count()}, load average = {os.getloadavg()}")
    print("best of repeats, wall-clock seconds of fit (overlap + partition + maps + topology)")
    print(
        f"{'log':<22} {'scans':>5} {'pts':>5} {'fit':>7} {'groups':>6} {'exact':>7} "
        f"{'groups':>6} {'ICP on':>7} {'ratio':>6} {'groups':>6}"
    )
    for path in logs:
        log = read_carmen(path)
        _target_row(path.name.split(".")[0], log_points(log), log.poses, repeats)
    world = office_world(n_rooms=DENSE_LOG["n_rooms"])
    poses = office_path(world, step=DENSE_LOG["step"])
    scans = raycast(
        world.segments,
        poses,
        DENSE_LOG["n_beams"],
        range_noise=0.01,
        rng=np.random.default_rng(0),
    )
    labels = _target_row("dense office (synthetic)", scans, poses, 1, exact=False, icp=False)
    truth = world.region_labels(poses)
    print(
        f"  dense office: purity {purity(truth, labels):.3f}, "
        f"ARI {adjusted_rand_index(truth, labels):+.3f}, {len(scans)} scans, "
        f"{sum(map(len, scans))} points"
    )
    print("targets: each real log <= 0.3 s, dense office <= 10 s, ICP on <= 3x ICP off")


def bench_incremental(start: int = 1000, added: int = 100) -> None:
    """``partial_fit`` one scan at a time after ``start`` scans (target <= 20 ms per scan),
    beside ``fit`` of the same scans in the same run, and the groups of both."""
    print(f"os.cpu_count() = {os.cpu_count()}, load average = {os.getloadavg()}")
    world = office_world(n_rooms=12)
    poses = office_path(world, step=0.25)[: start + added]
    scans = raycast(world.segments, poses, range_noise=0.01, rng=np.random.default_rng(0))
    model = ObservationGraphPartitioner(scan_matching=False)
    t0 = time.perf_counter()
    model.partial_fit(scans[:start], poses[:start])
    t_first = time.perf_counter() - t0
    per_scan = []
    for i in range(start, len(scans)):
        t0 = time.perf_counter()
        model.partial_fit(scans[i : i + 1], poses[i : i + 1])
        per_scan.append(time.perf_counter() - t0)
    batch = ObservationGraphPartitioner(scan_matching=False)
    t_batch = _best_of(lambda: batch.fit(scans, poses), 1)
    ms = 1000 * np.array(per_scan)
    truth = world.region_labels(poses)
    print(
        f"12-room office, 181 beams, 0.25 m apart: {start} scans by partial_fit in "
        f"{t_first:.2f} s, then {added} more one at a time"
    )
    print(
        f"  per scan: median {np.median(ms):.1f} ms, 95th percentile "
        f"{np.percentile(ms, 95):.1f} ms, max {ms.max():.1f} ms (target <= 20 ms)"
    )
    print(f"  fit of all {len(scans)} scans: {t_batch:.2f} s")
    for name, m in (("partial_fit", model), ("fit", batch)):
        print(
            f"  {name:<11} {m.n_groups_:>3} groups  purity {purity(truth, m.labels_):.3f}  "
            f"ARI {adjusted_rand_index(truth, m.labels_):+.3f}"
        )
    print(f"  ARI between them {adjusted_rand_index(batch.labels_, model.labels_):+.3f}")


def _target_row(tag, scans, poses, repeats, exact=True, icp=True) -> np.ndarray:
    fast = ObservationGraphPartitioner(scan_matching=False)
    t_fast = _best_of(lambda: fast.fit(scans, poses), repeats)
    cells = [
        f"{tag:<22} {len(scans):>5} {max(map(len, scans)):>5} {t_fast:>7.3f}",
        f"{fast.n_groups_:>6}",
    ]
    if exact:
        slow = ObservationGraphPartitioner(scan_matching=False, voxel_size=None)
        t_slow = _best_of(lambda: slow.fit(scans, poses), 1)
        cells.append(f"{t_slow:>7.3f} {slow.n_groups_:>6}")
    if icp:
        with_icp = ObservationGraphPartitioner(scan_matching=True)
        t_icp = _best_of(lambda: with_icp.fit(scans, poses), repeats)  # as t_fast: a ratio
        cells.append(f"{t_icp:>7.3f} {t_icp / t_fast:>6.1f} {with_icp.n_groups_:>6}")
    print(" ".join(cells))
    return fast.labels_


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--targets", action="store_true", help="the speed targets")
    parser.add_argument(
        "--carmen",
        action="append",
        type=Path,
        metavar="LOG",
        help="a real Carmen log for --targets (repeatable; default: the Radish logs in the "
        f"folder {RADISH_VAR} names)",
    )
    parser.add_argument("--incremental", action="store_true", help="partial_fit per scan")
    args = parser.parse_args()
    if args.targets:
        try:
            logs = args.carmen or [radish_log(name) for name in RADISH_LOGS]
        except DataHomeError as err:
            parser.error(f"{err}; or give --carmen LOG")
        bench_targets(logs)
    if args.incremental:
        bench_incremental()
    if not (args.targets or args.incremental):
        bench_cost()


if __name__ == "__main__":
    main()
