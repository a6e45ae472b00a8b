"""Every mapping task on held-out worlds: the test worlds of each family beside the canonical
world, with the gap.

    topomap heldout --worlds 20 --out out/heldout [--jobs 2] [--seeds 0]

runs one cell (:mod:`scripts.heldout.cells`) per world and seed: the family's first ``--worlds``
held-out test worlds (:func:`scenes.families.splits.held_out_worlds`) and its canonical world,
on a process pool. Cells are cached, so a second call with more worlds computes only the new
ones. The summary: per family and task, the mean over held-out worlds with its bootstrap 95%
interval, the canonical world's value, the gap, ours paired against scikit-learn's, and the
worlds past the target; written as ``heldout.json`` and ``heldout.md``.
"""

from __future__ import annotations

import argparse
import multiprocessing as mp
import os
from concurrent.futures import ProcessPoolExecutor, as_completed
from pathlib import Path

import numpy as np

from common.fileio import atomic_write_bytes, write_json
from scenes.families import FAMILIES, SPLITS_VERSION, held_out_worlds
from scripts.heldout.cells import MANIFOLD_Q, TASKS, manifold_errors, run_cell

__all__ = ["evaluate_heldout", "summarise"]

ERROR_TARGET = 0.15  # a world's clustering error past this is a failure, as in the protocol


def plan(families, count: int, seeds) -> list[tuple[str, int]]:
    """(world, seed) of every cell: each family's canonical world and held-out test worlds."""
    out = []
    for family in families:
        for world in (family, *held_out_worlds(family, count)):
            out += [(world, int(s)) for s in seeds]
    return out


def _one(args) -> dict:
    import sim  # noqa: F401  (headless GL before mujoco in a fresh worker)
    from common.blas import on_one_blas_thread

    # the workers share the cores: one BLAS thread each (common.blas says why)
    return on_one_blas_thread(run_cell, *args)


def evaluate_heldout(
    out: Path,
    families=FAMILIES,
    count: int = 20,
    seeds=(0,),
    frames: int = 150,
    tasks=TASKS,
    jobs: int | None = None,
    data_root: Path | None = None,
    progress: bool = True,
) -> dict:
    """Run (or resume) every cell of :func:`plan`, then :func:`summarise` them into
    ``out/heldout.json`` and ``out/heldout.md``; returns the summary."""
    from tqdm.auto import tqdm

    out = Path(out)
    data_root = out / "data" if data_root is None else Path(data_root)
    cells = plan(families, count, seeds)
    args = [(w, s, out, data_root, frames, tuple(tasks)) for w, s in cells]
    jobs = max(1, min(jobs or os.cpu_count() or 1, len(args)))
    results = []
    bar = tqdm(total=len(args), desc="held-out cells", unit="cell", disable=not progress)
    if jobs == 1:
        for a in args:
            results.append(_one(a))
            bar.update(1)
    else:
        with ProcessPoolExecutor(jobs, mp_context=mp.get_context("spawn")) as pool:
            for f in as_completed([pool.submit(_one, a) for a in args]):
                results.append(f.result())
                bar.update(1)
    bar.close()
    summary = summarise(results, frames=frames)
    write_json(out / "heldout.json", {"summary": summary, "cells": results})
    atomic_write_bytes(out / "heldout.md", format_summary(summary).encode())
    return summary


def _interval(values, seed: int = 0) -> dict:
    from scripts.manifold import bootstrap_mean

    return bootstrap_mean(np.asarray(values, float), np.random.default_rng(seed))


def summarise(cells: list[dict], frames: int) -> dict:
    """Per family: each task on the canonical world and over the held-out worlds."""
    from scripts.manifold import OURS, SKLEARN_DEFAULT

    out = {"splits_version": SPLITS_VERSION, "frames": frames, "q": MANIFOLD_Q, "families": {}}
    for family in sorted({c["family"] for c in cells}):
        canon = [c for c in cells if c["world"] == family]
        held = [c for c in cells if c["family"] == family and c["world"] != family]
        fam = {"worlds": sorted({c["world"] for c in held}), "manifold": {}, "grouping": {}}
        for method in (OURS, SKLEARN_DEFAULT):
            e_held, e_can = manifold_errors(held, method), manifold_errors(canon, method)
            if len(e_held):
                fam["manifold"][method] = {
                    "held_out": _interval(e_held),
                    "canonical": float(e_can.mean()) if len(e_can) else None,
                    "worlds_past_target": int(np.sum(e_held > ERROR_TARGET)),
                    "errors": e_held.tolist(),
                }
        ours, theirs = manifold_errors(held, OURS), manifold_errors(held, SKLEARN_DEFAULT)
        if len(ours) and len(ours) == len(theirs):
            fam["manifold"]["ours_minus_sklearn"] = _interval(ours - theirs)
        for key in ("purity", "max_groups_per_manifold"):
            held_v = [c["tasks"]["grouping"][key] for c in held if "grouping" in c["tasks"]]
            can_v = [c["tasks"]["grouping"][key] for c in canon if "grouping" in c["tasks"]]
            if held_v:
                fam["grouping"][key] = {
                    "held_out": _interval(held_v),
                    "canonical": float(np.mean(can_v)) if can_v else None,
                    "values": held_v,
                }
        out["families"][family] = fam
    return out


def _fmt(s: dict, pct: bool) -> str:
    f = (lambda v: f"{100 * v:.1f}%") if pct else (lambda v: f"{v:.3f}")
    return f"{f(s['mean'])} [{f(s['lo'])}, {f(s['hi'])}]"


def format_summary(summary: dict) -> str:
    """The summary as a markdown table: canonical, held-out and gap per family, task, method."""
    lines = [
        "| family | task | method | canonical world | held-out worlds [95% interval] | gap | n |",
        "|---|---|---|---|---|---|---|",
    ]
    for family, fam in summary["families"].items():
        for method, m in fam["manifold"].items():
            if method == "ours_minus_sklearn":
                lines.append(
                    f"| {family} | clustering error | ours minus scikit-learn | | "
                    f"{_fmt(m, True)} | | {m['n']} |"
                )
                continue
            h, c = m["held_out"], m["canonical"]
            gap = "" if c is None else f"{100 * (h['mean'] - c):+.1f} points"
            canon = "" if c is None else f"{100 * c:.1f}%"
            lines.append(
                f"| {family} | clustering error | {method} | {canon} | "
                f"{_fmt(h, True)} | {gap} | {h['n']} |"
            )
        for key, g in fam["grouping"].items():
            h, c = g["held_out"], g["canonical"]
            gap = "" if c is None else f"{h['mean'] - c:+.3f}"
            canon = "" if c is None else f"{c:.3f}"
            lines.append(
                f"| {family} | grouping {key.replace('_', ' ')} | partitioner (odometry + "
                f"ICP) | {canon} | {_fmt(h, False)} | {gap} | {h['n']} |"
            )
    return "\n".join(lines) + "\n"


def build_parser(parser: argparse.ArgumentParser | None = None) -> argparse.ArgumentParser:
    from scripts.args import positive_int

    p = parser or argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    p.add_argument("--families", nargs="+", choices=FAMILIES, default=list(FAMILIES))
    p.add_argument(
        "--worlds",
        type=positive_int,
        default=20,
        help="held-out test worlds per family (default 20)",
    )
    p.add_argument("--seeds", type=int, nargs="+", default=[0], help="dataset seeds per world")
    p.add_argument("--frames", type=positive_int, default=150, help="frames per drive")
    p.add_argument("--tasks", nargs="+", choices=TASKS, default=list(TASKS))
    p.add_argument("--jobs", type=positive_int, default=None, help="worker processes")
    p.add_argument("--out", type=Path, default=Path("out/heldout"))
    p.add_argument("--data", type=Path, default=None, help="dataset folder (default OUT/data)")
    return p


def run(args) -> int:
    if any(s < 0 for s in args.seeds):
        raise SystemExit("topomap heldout: --seeds must be integers >= 0")
    summary = evaluate_heldout(
        args.out,
        args.families,
        args.worlds,
        args.seeds,
        args.frames,
        args.tasks,
        args.jobs,
        args.data,
    )
    print(format_summary(summary), end="")
    print(f"wrote {args.out / 'heldout.json'} and {args.out / 'heldout.md'}")
    return 0


def main(argv=None) -> int:
    return run(build_parser().parse_args(argv))


if __name__ == "__main__":
    raise SystemExit(main())
