"""Every benchmark of the project in one command, as one markdown table beside the targets.

    .venv/bin/python bench/run_all.py [--quick] [--out bench/results.md]

Runs the simulator (``bench_sim``; the registered envs under ``gymnasium.utils.performance``
in group ``envs``), manifold clustering (``bench_manifold``), observation
grouping (``bench_partition``), servo (``bench_servo``) and policy-process boundary
(``bench_policy_boundary``) measurements by importing their
functions, and writes a table with the machine (CPU model, core count, load) and each figure
beside its target. ``--quick`` (about a minute) uses fewer repeats, skips the
dataset collection and the full-resolution clustering, stops the scaling at n = 600 and times
one servo episode in the hallway. ``--only sim manifold`` runs some groups.
"""

from __future__ import annotations

import argparse
import os
import platform
import sys
import time
import warnings
from collections.abc import Callable
from dataclasses import asdict, dataclass
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
sys.path[:0] = [str(ROOT), str(ROOT / "bench")]

import sim  # noqa: E402, F401  (headless GL before mujoco)
from scripts.tables import Column, Table  # noqa: E402

DEFAULT_OUT = ROOT / "bench" / "results.md"


@dataclass
class Row:
    area: str
    measure: str
    value: str
    target: str = ""
    met: bool | None = None  # None: no target


def _num(value: float) -> str:
    """3 significant figures, without exponents: 12,000 / 338 / 3.04 / 0.0813."""
    return f"{value:,.0f}" if abs(value) >= 100 else f"{value:.3g}"


def _row(area, measure, value: float, unit: str, target: float | None = None, at_most=True):
    """A row with ``value`` formatted to 3 significant figures and its target checked."""
    text = f"{_num(value)} {unit}".strip()
    if target is None:
        return Row(area, measure, text)
    sign = "<=" if at_most else ">="
    met = value <= target if at_most else value >= target
    return Row(area, measure, text, f"{sign} {target:g} {unit}".strip(), met)


def machine() -> dict[str, str]:
    from scripts.report import machine as report_machine

    info = report_machine()
    info["load average at start (1, 5, 15 min)"] = ", ".join(f"{x:.2f}" for x in os.getloadavg())
    info["python"] = platform.python_version()
    return info


# --------------------------------------------------------------------------- simulator


def sim_rows(quick: bool) -> list[Row]:
    import bench_sim as bs

    n = 100 if quick else 300
    rows = []
    for world in ("hallway", "lawn"):
        rows.append(
            _row(
                "sim",
                f"env steps/s, camera + laser, {world}",
                bs.env_steps_per_s(world, ("image", "scan"), n),
                "steps/s",
                150,
                at_most=False,
            )
        )
        rows.append(
            _row(
                "sim",
                f"env steps/s, laser only, {world}",
                bs.env_steps_per_s(world, ("scan",), n),
                "steps/s",
            )
        )
        rows.append(
            _row("sim", f"camera frames/s 320x240, {world}", bs.camera_fps(world, n), "frames/s")
        )
        rows.append(
            _row(
                "sim",
                f"laser scans/s (361 beams), {world}",
                bs.scans_per_s(world, 10 * n),
                "scans/s",
                3000,
                at_most=False,
            )
        )
    if not quick:
        rows.append(_row("sim", "default dataset, 900 frames", bs.dataset_seconds(), "s", 30))
    return rows


def env_rows(quick: bool) -> list[Row]:
    """The registered envs' steps/s under random actions (``gymnasium.utils.performance``), as
    ``gym.make`` gives them: the laser-only navigation env is the fast path for RL on scans.
    The servo envs read the default dataset's map (``out/dataset``, collected if missing)."""
    import bench_sim as bs

    from servo.maps import load_or_build, map_paths
    from sim.collect import collect_dataset

    seconds = 2.0 if quick else 5.0
    dataset = collect_dataset(ROOT / "out" / "dataset", progress=False)  # reused when present
    rows = []
    for world, name in (("hallway", "Hallway"), ("lawn", "Lawn")):
        for what, kwargs in (("camera + laser", {}), ("laser only", {"sensors": ("scan",)})):
            rate = bs.gym_steps_per_s(f"topomap/{name}-v0", seconds, **kwargs)
            rows.append(_row("envs", f"topomap/{name}-v0, {what}", rate, "steps/s"))
        cache = ROOT / "out" / "servo-maps"
        m = load_or_build(world, dataset, cache, progress=False)
        path = str(map_paths(cache, world, m.key)[0])  # the cached map, passed by its path
        rate = bs.gym_steps_per_s(f"topomap/{name}Servo-v0", seconds, servo_map=path)
        rows.append(_row("envs", f"topomap/{name}Servo-v0", rate, "steps/s"))
    return rows


# --------------------------------------------------------------------------- manifold clustering


def manifold_rows(quick: bool) -> list[Row]:
    import bench_manifold as bm
    from sklearn.cluster import SpectralClustering

    from mapping.manifold import ManifoldClustering

    rows = []
    for d in (2000,) if quick else (2000, 230_400):
        X, _ = bm.branching_sequences(150, d, np.random.default_rng(0))
        train = X[np.arange(len(X)) % 2 == 0]
        model = ManifoldClustering(8, 35)
        rows.append(
            _row(
                "manifold",
                f"fit 600 points, K=8, Q=35, d={d}",
                bm._time(lambda model=model, X=train: model.fit(X)),
                "s",
                10,
            )
        )
        # the targets for one view: 0.5 ms at d=2000, 2 ms for a 320x240 RGB image
        target = 0.5 if d == 2000 else 2.0
        for tol in (0.0, 1e-4):
            if tol:
                model.set_params(projection_tol=tol).fit(train)
            for name, call in (
                ("signal", lambda model=model, x=X[1]: model.signal(x, 0)),
                ("predict", lambda model=model, x=X[1:2]: model.predict(x)),
            ):
                rows.append(
                    _row(
                        "manifold",
                        f"{name}, one view, d={d}, projection_tol={tol:g} (median of 50)",
                        bm._median_ms(call)[0],  # wall (the CPU time is [1])
                        "ms",
                        target if tol else None,
                    )
                )
    for n in (300, 600) if quick else (300, 600, 1200, 2400):
        X, _ = bm.branching_sequences(n // 8, 2000, np.random.default_rng(1))
        q = min(35, n // 16)
        ours = bm._time(lambda X=X, q=q: ManifoldClustering(8, q).fit(X))
        sk = SpectralClustering(8, affinity="nearest_neighbors", n_neighbors=10, random_state=0)
        with warnings.catch_warnings():  # "graph is not fully connected": the branches
            warnings.simplefilter("ignore", UserWarning)
            theirs = bm._time(lambda X=X, sk=sk: sk.fit(X))
        # the target: n = 2400 in 5 s (kernel="auto" is the k-NN graph path above 1000)
        target = 5.0 if n == 2400 else None
        rows.append(
            Row(
                "manifold",
                f"fit n={n}, K=8, d=2000: ours / sklearn SpectralClustering (10-NN graph)",
                f"{_num(ours)} s / {_num(theirs)} s (ratio {ours / theirs:.1f})",
                "" if target is None else f"<= {target:g} s",
                None if target is None else ours <= target,
            )
        )
    return rows


# --------------------------------------------------------------------------- observation grouping


def partition_rows(quick: bool) -> list[Row]:
    import bench_partition as bp
    from threadpoolctl import threadpool_limits

    from mapping.grouping import ObservationGraphPartitioner

    rows = []
    cases = [(4, 77, 0.05), (104, 2000, 5.0)]
    if not quick:
        cases.insert(1, (26, None, None))
    for n_rooms, paper_n, target in cases:
        _, scans, poses = bp.office_data(n_rooms, bp.STEP)
        # Poses given, as in the paper's timing (no ICP).
        model = ObservationGraphPartitioner(match_distance=bp.DELTA, scan_matching=False)
        repeats = (5 if quick else 15) if len(scans) < 300 else (1 if quick else 2)
        with threadpool_limits(1):  # small LAPACK calls only contend for cores
            seconds = bp._best_of(lambda m=model, s=scans, p=poses: m.fit(s, p), repeats)
        what = f"fit {len(scans)} scans ({n_rooms}-room office, best of {repeats}, BLAS 1 thread)"
        if paper_n is not None and abs(len(scans) - paper_n) > 0.1 * paper_n:
            what += f"; target is for {paper_n} scans"
        rows.append(_row("grouping", what, seconds, "s", target))
    return rows


# --------------------------------------------------------------------------- servo


def servo_rows(quick: bool) -> list[Row]:
    """``bench_servo.bench_world`` per world: controller step (the target), the episode's
    one-off global localisation, the env step and the map build; ``bench_runner``: the
    evaluation runner's own time per step beside the env step. Needs the default dataset
    (``out/dataset``, collected here if missing)."""
    import bench_servo as bsv

    from sim.collect import collect_dataset

    dataset = collect_dataset(ROOT / "out" / "dataset", progress=False)  # reused when present
    rows = []
    episodes = 1 if quick else 3
    for world in ("hallway",) if quick else ("hallway", "lawn"):
        r = bsv.bench_world(world, episodes, dataset, ROOT / "out" / "servo-maps")
        steps = f"{world}, {r['steps']} steps of {episodes} episode(s)"
        rows += [
            _row(
                "servo",
                f"controller step (localise + decide), median, {steps}",
                r["act median (ms)"],
                "ms",
                10,
            ),
            _row("servo", f"controller step, 95th percentile, {world}", r["act p95 (ms)"], "ms"),
            _row(
                "servo",
                f"global localisation at an episode's start, {world}",
                r["global localisation (ms)"],
                "ms",
            ),
            _row("servo", f"servo env step, {world}", r["env step (ms)"], "ms"),
            _row("servo", f"servo map build, {world}", r["map build (s)"], "s"),
        ]
    import bench_runner as brn

    r = brn.runner_overhead("hallway", episodes, dataset=dataset, cache=ROOT / "out" / "servo-maps")
    measure = f"runner overhead per step, median, hallway, {r['steps']} steps (no F, no video)"
    rows += [
        _row("servo", measure, r["runner_ms"], "ms", 1),
        _row("servo", "env step beside it, median, hallway", r["env_step_ms"], "ms"),
    ]
    r = bsv.known_limitation(dataset, ROOT / "out" / "servo-maps")
    _, start, target, _ = bsv.KNOWN_LIMITATION
    measure = f"known limitation {start} -> {target} (docs/guides/servo.md): outcome"
    rows.append(Row("servo", measure, f"{r['reason']}, {r['final_distance']:.2f} m"))
    return rows


def boundary_rows(quick: bool) -> list[Row]:
    """``bench_policy_boundary.measure``: an outside policy's ``act`` across its process
    boundary against the same ``act`` in this process, on the same observations (the
    overhead's target: at most 2 ms a step), and the ratio of a whole step's time."""
    import bench_policy_boundary as bpb

    r = bpb.measure(100 if quick else 300, sandbox=False)
    overhead = f"policy process overhead per step, median, {r['steps']} steps"
    ratio = "a step across the boundary / in process (env step included)"
    return [
        _row("boundary", overhead, r["overhead_ms"], "ms", bpb.TARGET_MS),
        _row("boundary", "the same act in process, median", r["in_process_ms"], "ms"),
        _row("boundary", ratio, r["step_ratio"], "x"),
    ]


# --------------------------------------------------------------------------- table


GROUPS: dict[str, Callable[[bool], list[Row]]] = {
    "sim": sim_rows,
    "envs": env_rows,
    "manifold": manifold_rows,
    "grouping": partition_rows,
    "servo": servo_rows,
    "boundary": boundary_rows,
}


COLUMNS = (  # the results table (scripts.tables): the same renderer as every other table
    Column("area", "area"),
    Column("measure", "measure"),
    Column("value", "value"),
    Column("target", "target"),
    Column("met", "met"),
)


def to_markdown(rows: list[Row], info: dict[str, str], seconds: float, quick: bool) -> str:
    lines = ["# Benchmarks", ""]
    lines += [f"- {k}: {v}" for k, v in info.items()]
    lines += [
        f"- mode: {'quick' if quick else 'full'}; total {seconds:.0f} s",
        "- command: `.venv/bin/python bench/run_all.py" + (" --quick`" if quick else "`"),
        "",
    ]
    met = {None: "", True: "yes", False: "**no**"}  # no target: an empty cell
    table = Table.of(COLUMNS, [{**asdict(r), "met": met[r.met]} for r in rows])
    return "\n".join(lines) + "\n" + table.to_markdown()


def main(argv: list[str] | None = None) -> int:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--quick", action="store_true", help="fewer repeats, smaller sizes")
    p.add_argument("--out", default=str(DEFAULT_OUT), help="markdown file to write")
    p.add_argument("--only", choices=tuple(GROUPS), nargs="*", help="run only these groups")
    args = p.parse_args(argv)
    os.chdir(ROOT)  # the benchmarks read the default dataset at out/dataset
    info = machine()
    start = time.perf_counter()
    rows: list[Row] = []
    for name, fn in GROUPS.items():
        if args.only and name not in args.only:
            continue
        t0 = time.perf_counter()
        print(f"== {name}", flush=True)
        rows += fn(args.quick)
        print(f"== {name}: {time.perf_counter() - t0:.0f} s", flush=True)
    info["load average at end"] = ", ".join(f"{x:.2f}" for x in os.getloadavg())
    text = to_markdown(rows, info, time.perf_counter() - start, args.quick)
    from common.fileio import atomic_write_bytes

    out = Path(args.out)
    out.parent.mkdir(parents=True, exist_ok=True)
    atomic_write_bytes(out, text.encode())
    print(text)
    print(f"wrote {out}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
