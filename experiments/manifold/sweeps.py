"""Synthetic tables and sweeps: every method on the paper's sets and on branching
sequences at several n, and the paper's claim tested where it should matter.

Per-cluster sigma should beat one sigma when no single sigma both connects the sparsest curve
(sigma above its sampling interval) and separates the curves (sigma below the gap between
them), i.e. when ``gap / coarsest interval`` is near or below 1, and more so the larger the
density ratio between the curves. Two sweeps of `mapping.manifold.lines_variable_spacing`
test that:

* ``gap``: intervals (0.01, 0.025, 0.05) fixed, the gap between the lines from 0.5 to 6 times
  the coarsest interval;
* ``density``: the gap fixed at 0.1, intervals ``0.01 * (1, sqrt(r), r)`` for density ratios r
  from 1 to 8 (so the coarsest interval grows too: the ratio is printed beside).

Each point is drawn ``repeats`` times with Gaussian noise 0.002 (seeds 0, 1, ...), Q = 20.

Usage::

    python -m experiments.manifold.sweeps --out out/sweeps [--repeats 2] [--figure out/sweeps.png]
"""

from __future__ import annotations

import argparse
import json
from pathlib import Path

import numpy as np

from common.fileio import atomic_write_bytes, read_json
from mapping.manifold import branching_sequences, lines_variable_spacing, make_all
from scripts.manifold.methods import METHODS, score_methods

NOISE = 0.002
GAP_RATIOS = (0.5, 1.0, 1.5, 2.0, 3.0, 6.0)
DENSITY_RATIOS = (1.0, 2.0, 4.0, 6.0, 8.0)
BRANCHING_N = (38, 75, 150)  # per sequence: n = 304, 600, 1200 points, half of them train
SYNTHETIC_K, SYNTHETIC_Q = 3, 20
BRANCHING_K, BRANCHING_Q, BRANCHING_D = 8, 35, 2000


def _rows(tag: dict, X, y, K, Q, split: bool) -> list[dict]:
    if split:  # even points build the model, odd points test it
        rows = score_methods(X[::2], y[::2], K, Q, X[1::2], y[1::2])
    else:
        rows = score_methods(X, y, K, Q)
    return [{**tag, **r} for r in rows]


def tables(progress: bool = True) -> list[dict]:
    """Every method on the four clean synthetic sets (all points) and on the branching
    sequences at each n of ``BRANCHING_N`` (d = 2000, even frames train, odd frames test)."""
    from tqdm.auto import tqdm

    rows = []
    for name, (X, y) in tqdm(make_all().items(), disable=not progress, desc="synthetic sets"):
        rows += _rows({"set": name, "n": len(y)}, X, y, SYNTHETIC_K, SYNTHETIC_Q, split=False)
    for m in tqdm(BRANCHING_N, disable=not progress, desc="branching sequences"):
        X, y = branching_sequences(m, BRANCHING_D, np.random.default_rng(0))
        Q = min(BRANCHING_Q, (len(y) // 2) // BRANCHING_K)
        tag = {"set": f"branching n={len(y)} ({len(y[::2])} train)", "n": len(y), "Q": Q}
        rows += _rows(tag, X, y, BRANCHING_K, Q, split=True)
    return rows


def sweep_points(kind: str) -> list[dict]:
    """The (spacings, gap) of each point of the ``gap`` or ``density`` sweep."""
    if kind == "gap":
        spacings = (0.01, 0.025, 0.05)
        return [{"ratio": r, "spacings": spacings, "gap": r * spacings[-1]} for r in GAP_RATIOS]
    if kind == "density":
        return [
            {"ratio": r, "spacings": (0.01, 0.01 * np.sqrt(r), 0.01 * r), "gap": 0.1}
            for r in DENSITY_RATIOS
        ]
    raise ValueError(f"sweep kind must be 'gap' or 'density', got {kind!r}")


def sweep(kind: str, repeats: int = 2, progress: bool = True) -> list[dict]:
    """Clustering error (all points) of every method at each point of a sweep, per repeat."""
    from tqdm.auto import tqdm

    points = sweep_points(kind)
    rows = []
    with tqdm(total=len(points) * repeats, disable=not progress, desc=f"{kind} sweep") as bar:
        for p in points:
            for seed in range(repeats):
                rng = np.random.default_rng(seed)
                X, y = lines_variable_spacing(p["spacings"], p["gap"], noise=NOISE, rng=rng)
                tag = {
                    "sweep": kind,
                    "ratio": p["ratio"],
                    "gap_over_coarsest": p["gap"] / p["spacings"][-1],
                    "seed": seed,
                }
                rows += _rows(tag, X, y, SYNTHETIC_K, SYNTHETIC_Q, split=False)
                bar.update()
    return rows


def plot_sweeps(rows: list[dict], path: Path) -> Path:
    """Mean error (over repeats; bars: min-max) against the ratio, one panel per sweep."""
    from scripts.grouping.plots import agg_pyplot, save_figure

    plt = agg_pyplot()
    kinds = [k for k in ("gap", "density") if any(r["sweep"] == k for r in rows)]
    fig, axes = plt.subplots(1, len(kinds), figsize=(6 * len(kinds), 4), squeeze=False)
    labels = {
        "gap": "gap between lines / coarsest sampling interval",
        "density": "density ratio (coarsest / finest interval), gap 0.1",
    }
    for ax, kind in zip(axes[0], kinds, strict=True):
        for method in METHODS:
            sel = [r for r in rows if r["sweep"] == kind and r["method"] == method]
            ratios = sorted({r["ratio"] for r in sel})
            errs = [[r["train_error"] for r in sel if r["ratio"] == q] for q in ratios]
            mean = np.array([np.mean(e) for e in errs])
            lo = mean - np.array([min(e) for e in errs])
            hi = np.array([max(e) for e in errs]) - mean
            style = "--" if "ceiling" in method else "-"
            ax.errorbar(ratios, mean, yerr=[lo, hi], fmt=style + "o", ms=4, capsize=3, label=method)
        ax.set_xlabel(labels[kind])
        ax.set_ylabel("clustering error")
        ax.set_ylim(-0.02, 0.75)
        ax.grid(alpha=0.3)
    axes[0, 0].legend(fontsize=7)
    fig.tight_layout()
    return save_figure(fig, path)


def markdown_table(rows: list[dict], key: str) -> str:
    """Rows keyed by ``key`` ("set" or "ratio") x method; errors as train / test."""
    keys = list(dict.fromkeys(r[key] for r in rows))
    lines = [f"| {key} | " + " | ".join(METHODS) + " |", "|---" * (len(METHODS) + 1) + "|"]
    for k in keys:
        cells = []
        for m in METHODS:
            sel = [r for r in rows if r[key] == k and r["method"] == m]
            train = np.mean([r["train_error"] for r in sel])
            tests = [r["test_error"] for r in sel if r["test_error"] is not None]
            cells.append(f"{train:.3f}" + (f" / {np.mean(tests):.3f}" if tests else ""))
        lines.append(f"| {k} | " + " | ".join(cells) + " |")
    return "\n".join(lines)


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--out", type=Path, required=True, help="folder for the JSON results")
    parser.add_argument("--repeats", type=int, default=2, help="noise draws per sweep point")
    parser.add_argument("--figure", type=Path, default=None, help="PNG of the sweeps")
    parser.add_argument(
        "--parts",
        nargs="+",
        default=["tables", "gap", "density"],
        choices=("tables", "gap", "density"),
    )
    args = parser.parse_args(argv)
    if args.repeats < 1:
        parser.error("--repeats must be >= 1")
    args.out.mkdir(parents=True, exist_ok=True)
    for part in args.parts:
        rows = tables() if part == "tables" else sweep(part, args.repeats)
        atomic_write_bytes(args.out / f"{part}.json", (json.dumps(rows, indent=2) + "\n").encode())
        print(markdown_table(rows, "set" if part == "tables" else "ratio"))
    swept = [
        r
        for p in ("gap", "density")
        if (args.out / f"{p}.json").exists()
        for r in read_json(args.out / f"{p}.json")
    ]
    if args.figure is not None and swept:
        print(f"wrote {plot_sweeps(swept, args.figure)}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
