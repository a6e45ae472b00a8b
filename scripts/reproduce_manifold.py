"""Reproduce Grudic & Mulligan's experiments (Section III): synthetic sets and the 8 manifolds.

Usage::

    topomap reproduce --data out/dataset --out out/reproduce [--json]

Synthetic (Figures 1-5): the four sets of :mod:`mapping.synthetic`, K = 3, Q = 20, clustered by
:class:`~mapping.ManifoldClustering`, best-sigma NCut (an oracle: sigma chosen on the labels, as
the paper did) and self-tuning spectral clustering. Real (Figure 6): every second frame of each
sequence of the dataset builds the map, the others are the test set, K = 8, Q = 35; the same
three methods on three feature sets (the paper's raw pixels, HSV colour histograms, laser
scans). Writes ``results.json`` and paper-style plots of true and predicted label against the
point or frame index; ``docs/manifold-clustering.md`` quotes the numbers.
"""

from __future__ import annotations

import argparse
import json
import time
from pathlib import Path

import numpy as np

from mapping import (
    ColorHistogramFeatures,
    ImageFeatures,
    ManifoldClustering,
    ScanFeatures,
    clustering_error,
)
from mapping.baselines import SelfTuningSpectralClustering, best_sigma_ncut
from mapping.synthetic import make_all
from scenes.fileio import atomic_write_bytes
from scripts.grouping_plots import agg_pyplot, save_figure

SYNTHETIC_K, SYNTHETIC_Q = 3, 20  # Section III-A
REAL_K, REAL_Q = 8, 35  # Section III-B
# The paper's claims, Section III: which method succeeds on which synthetic set, and the test
# errors on its image sequences.
PAPER_SYNTHETIC = {
    "parallel_lines": "both succeed",
    "lines_variable_spacing": "ours succeeds, NCut fails",
    "converging_paths": "ours succeeds, NCut fails",
    "spirals_3d": "ours succeeds, NCut fails",
}
PAPER_REAL = {"ours": 0.0289, "best-sigma NCut": 0.344}
METHODS = ("ours", "best-sigma NCut", "self-tuning")


def _progress(total: int, enabled: bool, desc: str):
    from tqdm.auto import tqdm

    return tqdm(total=total, disable=not enabled, desc=desc, unit="fit")


def _fit_three(X, y, K, Q, X_test=None):
    """(method, train labels, test labels or None, extra) for the three methods."""
    ours = ManifoldClustering(K, Q).fit(X)
    sweep = best_sigma_ncut(X, y, K)
    tuned = SelfTuningSpectralClustering(K).fit(X)
    out = []
    for name, model, extra in (
        ("ours", ours, {"leaves": int(ours.leaf_labels_.max() + 1)}),
        ("best-sigma NCut", sweep.model, {"sigma": sweep.sigma}),
        ("self-tuning", tuned, {}),
    ):
        test = None if X_test is None else model.predict(X_test)
        out.append((name, model.labels_, test, extra))
    return out


def synthetic_rows(progress: bool = True) -> tuple[list[dict], dict]:
    """Clustering error of the three methods on the four clean synthetic sets."""
    rows, labels = [], {}
    sets = make_all()
    with _progress(len(sets), progress, "synthetic sets") as bar:
        for name, (X, y) in sets.items():
            results = _fit_three(X, y, SYNTHETIC_K, SYNTHETIC_Q)
            labels[name] = (y, {m: lab for m, lab, _, _ in results})
            for method, lab, _, extra in results:
                rows.append(
                    {
                        "set": name,
                        "n": len(y),
                        "method": method,
                        "error": clustering_error(y, lab),
                        "paper_claim": PAPER_SYNTHETIC[name],
                        **extra,
                    }
                )
            bar.update()
    return rows, labels


def feature_sets(dataset) -> dict[str, tuple[str, object, np.ndarray]]:
    """name -> (sensor, transformer, raw readings) of the three compared feature sets."""
    images = dataset.concat("images")
    scans = dataset.concat("scans")
    max_range = float(dataset.meta["settings"]["laser"]["max_range"])
    return {
        "raw pixels 320x240 RGB (paper)": ("images", ImageFeatures(), images),
        "HSV histograms 8x4x4, 2x2 cells": ("images", ColorHistogramFeatures(), images),
        "laser ranges": ("scans", ScanFeatures(max_range=max_range), scans),
    }


def real_rows(dataset, progress: bool = True) -> tuple[list[dict], dict]:
    """Train and test error of the three methods on each feature set (paper split)."""
    y = dataset.concat("labels")
    train, test = dataset.paper_split()
    rows, labels = [], {}
    sets = feature_sets(dataset)
    with _progress(len(sets), progress, "8-manifold dataset") as bar:
        for name, (sensor, transformer, raw) in sets.items():
            start = time.perf_counter()
            X_train = transformer.fit_transform(raw[train])
            X_test = transformer.transform(raw[test])
            results = _fit_three(X_train, y[train], REAL_K, REAL_Q, X_test)
            labels[name] = (y[test], {m: t for m, _, t, _ in results})
            for method, lab, pred, extra in results:
                rows.append(
                    {
                        "sensor": sensor,
                        "features": name,
                        "dims": int(X_train.shape[1]),
                        "method": method,
                        "train_error": clustering_error(y[train], lab),
                        "test_error": clustering_error(y[test], pred),
                        "paper_error": PAPER_REAL.get(method) if sensor == "images" else None,
                        **extra,
                    }
                )
            rows[-1]["seconds_for_three_fits"] = time.perf_counter() - start
            bar.update()
    return rows, labels


def plot_labels(panels: dict[str, tuple[np.ndarray, dict]], path: Path, xlabel: str) -> Path:
    """Paper-style plot (Figures 2-6): true label (red stars) and predicted label (blue
    squares, mapped to the true labels by the Hungarian matching) against the index."""
    from mapping.metrics import best_matching

    plt = agg_pyplot()

    fig, axes = plt.subplots(
        len(panels), len(METHODS), figsize=(4.2 * len(METHODS), 2.2 * len(panels)), squeeze=False
    )
    for r, (name, (y, preds)) in enumerate(panels.items()):
        for c, method in enumerate(METHODS):
            pred = preds[method]
            mapping = best_matching(y, pred)
            shown = np.array([mapping.get(p, -1) for p in pred.tolist()])
            ax = axes[r, c]
            idx = np.arange(len(y))
            ax.plot(idx, y, "r*", ms=4, label="true")
            ax.plot(idx, shown, "bs", ms=3, mfc="none", label="predicted")
            ax.set_title(f"{name}: {method} ({clustering_error(y, pred):.1%})", fontsize=8)
            ax.set_xlabel(xlabel, fontsize=8)
            ax.tick_params(labelsize=7)
            if r == 0 and c == 0:
                ax.legend(fontsize=7, loc="upper left")
    fig.tight_layout()
    return save_figure(fig, path)


def reproduce(dataset_dir: str | Path, out_dir: str | Path, *, progress: bool = True) -> dict:
    """Run both reproductions; write ``results.json`` and the plots into ``out_dir``.

    Returns
    -------
    dict
        ``synthetic`` and ``real`` (lists of rows: errors per set / feature set and method,
        with the paper's claim or number beside them), ``figures`` (PNG paths relative to
        ``out_dir``) and ``timings`` (seconds per part).
    """
    from sim.dataset import load_dataset

    out = Path(out_dir)
    out.mkdir(parents=True, exist_ok=True)
    timings = {}
    start = time.perf_counter()
    synthetic, synthetic_labels = synthetic_rows(progress)
    timings["synthetic"] = time.perf_counter() - start
    start = time.perf_counter()
    real, real_labels = real_rows(load_dataset(dataset_dir), progress)
    timings["real"] = time.perf_counter() - start
    figures = [
        plot_labels(synthetic_labels, out / "synthetic_labels.png", "point index"),
        plot_labels(real_labels, out / "real_labels.png", "test frame index"),
    ]
    result = {
        "synthetic": synthetic,
        "real": real,
        "figures": [str(p.relative_to(out)) for p in figures],
        "timings": timings,
        "settings": {
            "synthetic": {"K": SYNTHETIC_K, "Q": SYNTHETIC_Q},
            "real": {"K": REAL_K, "Q": REAL_Q, "split": "even frames train, odd frames test"},
            "dataset": str(dataset_dir),
        },
    }
    atomic_write_bytes(out / "results.json", (json.dumps(result, indent=2) + "\n").encode())
    return result


def markdown_tables(result: dict) -> str:
    """The two tables of ``docs/manifold-clustering.md`` from a :func:`reproduce` result."""
    lines = ["| set | method | error | paper's claim |", "|---|---|---|---|"]
    for r in result["synthetic"]:
        lines.append(f"| {r['set']} | {r['method']} | {r['error']:.3f} | {r['paper_claim']} |")
    lines += ["", "| features | method | train error | test error | paper |"]
    lines.append("|---|---|---|---|---|")
    for r in result["real"]:
        paper = "--" if r["paper_error"] is None else f"{r['paper_error']:.1%}"
        lines.append(
            f"| {r['features']} | {r['method']} | {r['train_error']:.1%} | "
            f"{r['test_error']:.1%} | {paper} |"
        )
    return "\n".join(lines)


def build_parser(parser: argparse.ArgumentParser | None = None) -> argparse.ArgumentParser:
    parser = parser or argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--data", required=True, help="dataset directory (topomap collect)")
    parser.add_argument("--out", required=True, help="directory for results.json and plots")
    parser.add_argument("--json", action="store_true", help="print the results as JSON")
    return parser


def run(args) -> int:
    result = reproduce(args.data, args.out)
    print(json.dumps(result, indent=2) if args.json else markdown_tables(result))
    return 0


def main(argv: list[str] | None = None) -> int:
    return run(build_parser().parse_args(argv))


if __name__ == "__main__":
    raise SystemExit(main())
