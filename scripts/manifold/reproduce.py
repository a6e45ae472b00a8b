"""Reproduce Grudic & Mulligan's experiments (Section III): synthetic sets and the 8 manifolds.

Usage::

    topomap reproduce --data out/dataset --out out/reproduce [--json]

Synthetic (Figures 1-5): the four sets of `mapping.manifold.synthetic`, K = 3, Q = 20, clustered by
[`ManifoldClustering`][mapping.manifold.clustering.ManifoldClustering], best-sigma NCut (an oracle:
sigma chosen on the labels, as the paper did) and self-tuning spectral clustering. Real (Figure 6):
every second frame of each sequence of the dataset builds the map, the others are the test set, K =
8, Q = 35; the same three methods on three feature sets (the paper's raw pixels, HSV colour
histograms, laser scans). Writes ``results.json``, ``clusters.npz`` (every frame's cluster) and
paper-style plots of true and predicted label against the point or frame index;
``docs/guides/manifold-clustering.md`` quotes the numbers.

On a dataset without ground truth (imported from a robot's log, ``topomap import``) the same
methods run with K = ``--clusters`` (default the paper's 8) and write their clusters and plots,
without errors ("no ground-truth labels"); the oracle best-sigma NCut, which picks sigma by the
labels, is left out.
"""

from __future__ import annotations

import argparse
import json
import time
from pathlib import Path

import numpy as np

from common.fileio import atomic_write_bytes
from mapping import (
    ColorHistogramFeatures,
    ImageFeatures,
    ManifoldClustering,
    ScanFeatures,
    clustering_error,
)
from mapping.baselines import SelfTuningSpectralClustering, best_sigma_ncut
from mapping.manifold import make_all
from scripts.grouping import agg_pyplot, save_figure

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
NO_LABELS = "no ground-truth labels: clusters are not scored (errors: --)"
CLUSTERS_FILE = "clusters.npz"  # every frame's cluster per feature set and method
PAPER_PIXELS = (320, 240)  # the paper's raw-pixel resolution (width, height)
# The paper's 2.89 % / 34.4 % were measured on raw pixels: its numbers are shown beside that
# feature set only, never beside features the paper did not use.
PAPER_FEATURES = "raw pixels 320x240 RGB (paper)"


def _progress(total: int, enabled: bool, desc: str):
    from tqdm.auto import tqdm

    return tqdm(total=total, disable=not enabled, desc=desc, unit="fit")


def _fit_three(X, y, K, Q, X_test=None):
    """Fit the three methods; return (method, train labels, test labels or None, extra) each.

    Without labels ``y`` (None) the oracle best-sigma NCut is left out.
    """
    ours = ManifoldClustering(K, Q).fit(X)
    tuned = SelfTuningSpectralClustering(K).fit(X)
    fitted = [("ours", ours, {"leaves": int(ours.leaf_labels_.max() + 1)})]
    if y is not None:
        sweep = best_sigma_ncut(X, y, K)
        fitted.append(("best-sigma NCut", sweep.model, {"sigma": sweep.sigma}))
    out = []
    for name, model, extra in (*fitted, ("self-tuning", tuned, {})):
        test = None if X_test is None else model.predict(X_test)
        out.append((name, model.labels_, test, extra))
    return out


def synthetic_rows(progress: bool = True) -> tuple[list[dict], dict]:
    """Score the clustering error of the three methods on the four clean synthetic sets.

    Parameters
    ----------
    progress : bool, default True
        Whether to show a progress bar.

    Returns
    -------
    rows : list of dict
        One per set and method: its size, the error, the paper's claim and the method's
        extra facts.
    labels : dict
        Set name -> (true labels, {method: predicted labels}).
    """
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
    """Build the three compared feature sets of ``dataset``.

    Parameters
    ----------
    dataset : Dataset
        The dataset (``sim.dataset``), with images and scans.

    Returns
    -------
    dict
        Name -> (sensor, transformer, raw readings).
    """
    images = dataset.concat("images")
    scans = dataset.concat("scans")
    max_range = dataset.max_range
    if max_range is None:
        finite = scans[np.isfinite(scans)]
        max_range = float(finite.max()) if finite.size else 1.0
    # another camera's frames are brought to the paper's resolution first
    size = None if images.shape[2:0:-1] == PAPER_PIXELS else PAPER_PIXELS
    return {
        PAPER_FEATURES: ("images", ImageFeatures(size=size), images),
        "HSV histograms 8x4x4, 2x2 cells": ("images", ColorHistogramFeatures(), images),
        "laser ranges": ("scans", ScanFeatures(max_range=max_range), scans),
    }


def paper_error(features: str, method: str) -> float | None:
    """Return the paper's error for ``method``, only beside the feature set it was measured on.

    That set is raw pixels: beside HSV histograms or laser ranges the number would read as a
    claim the paper never made.

    Parameters
    ----------
    features : str
        The feature set's name.
    method : str
        The method's name.

    Returns
    -------
    float or None
        The paper's error, or None.
    """
    return PAPER_REAL.get(method) if features == PAPER_FEATURES else None


def real_rows(
    dataset, progress: bool = True, n_clusters: int | None = None
) -> tuple[list[dict], dict]:
    """Score the train and test error of the three methods on each feature set (paper split).

    Without ground truth: the clusters, no errors.

    Parameters
    ----------
    dataset : Dataset
        The dataset (``sim.dataset``).
    progress : bool, default True
        Whether to show a progress bar.
    n_clusters : int, optional
        K (default the paper's 8).

    Returns
    -------
    rows : list of dict
        One per feature set and method: sizes, K and Q, clusters, errors (None without
        ground truth), the paper's error, the train and test labels, and extra facts.
    labels : dict
        Feature set -> (true test labels or None, {method: predicted test labels}).

    Raises
    ------
    ValueError
        When ``n_clusters`` is below 1.
    """
    truth = dataset.has_ground_truth
    train, test = dataset.paper_split()
    y = dataset.concat("labels") if truth else np.full(len(train), -1)
    K = REAL_K if n_clusters is None else int(n_clusters)
    if K < 1:
        raise ValueError(f"n_clusters must be >= 1, got {n_clusters}")
    Q = max(1, min(REAL_Q, int(train.sum()) // K))  # K * Q must fit in the training frames
    rows, labels = [], {}
    sets = feature_sets(dataset)
    with _progress(len(sets), progress, "8-manifold dataset") as bar:
        for name, (sensor, transformer, raw) in sets.items():
            start = time.perf_counter()
            X_train = transformer.fit_transform(raw[train])
            X_test = transformer.transform(raw[test])
            results = _fit_three(X_train, y[train] if truth else None, K, Q, X_test)
            labels[name] = (y[test] if truth else None, {m: t for m, _, t, _ in results})
            for method, lab, pred, extra in results:
                rows.append(
                    {
                        "sensor": sensor,
                        "features": name,
                        "dims": int(X_train.shape[1]),
                        "method": method,
                        "K": K,
                        "Q": Q,
                        "clusters": len(np.unique(lab)),
                        "train_error": clustering_error(y[train], lab) if truth else None,
                        "test_error": clustering_error(y[test], pred) if truth else None,
                        "paper_error": paper_error(name, method),
                        "train_labels": lab,
                        "test_labels": pred,
                        **extra,
                    }
                )
            rows[-1]["seconds_for_three_fits"] = time.perf_counter() - start
            bar.update()
    return rows, labels


def plot_labels(panels: dict[str, tuple[np.ndarray, dict]], path: Path, xlabel: str) -> Path:
    """Plot true and predicted labels against the index, paper-style (Figures 2-6).

    True labels are red stars, predicted labels blue squares, mapped to the true labels by the
    Hungarian matching. A panel whose true labels are None (no ground truth) shows the
    predicted clusters as they are.

    Parameters
    ----------
    panels : dict
        Row name -> (true labels or None, {method: predicted labels}).
    path : Path
        The PNG file to write.
    xlabel : str
        The x-axis label.

    Returns
    -------
    Path
        ``path``.
    """
    from mapping.metrics import best_matching

    plt = agg_pyplot()
    methods = [m for m in METHODS if any(m in preds for _, preds in panels.values())]
    fig, axes = plt.subplots(
        len(panels), len(methods), figsize=(4.2 * len(methods), 2.2 * len(panels)), squeeze=False
    )
    for r, (name, (y, preds)) in enumerate(panels.items()):
        for c, method in enumerate(methods):
            pred, ax = preds[method], axes[r, c]
            idx = np.arange(len(pred))
            if y is None:
                ax.plot(idx, pred, "bs", ms=3, mfc="none", label="cluster")
                ax.set_title(f"{name}: {method} (no ground-truth labels)", fontsize=8)
            else:
                mapping = best_matching(y, pred)
                shown = np.array([mapping.get(p, -1) for p in pred.tolist()])
                ax.plot(idx, y, "r*", ms=4, label="true")
                ax.plot(idx, shown, "bs", ms=3, mfc="none", label="predicted")
                error = clustering_error(y, pred)
                ax.set_title(f"{name}: {method} ({error:.1%})", fontsize=8)
            ax.set_xlabel(xlabel, fontsize=8)
            ax.tick_params(labelsize=7)
            if r == 0 and c == 0:
                ax.legend(fontsize=7, loc="upper left")
    fig.tight_layout()
    return save_figure(fig, path)


def reproduce(
    dataset_dir: str | Path,
    out_dir: str | Path,
    *,
    progress: bool = True,
    n_clusters: int | None = None,
) -> dict:
    """Run both reproductions; write ``results.json``, ``clusters.npz`` and the plots.

    On a dataset without ground truth the errors are None and ``ground_truth`` is False.

    Parameters
    ----------
    dataset_dir : str or Path
        The dataset (``topomap collect``).
    out_dir : str or Path
        The output directory, created if missing.
    progress : bool, default True
        Whether to show progress bars.
    n_clusters : int, optional
        K on the dataset (default the paper's 8).

    Returns
    -------
    dict
        ``synthetic`` and ``real`` (lists of rows: errors per set / feature set and method,
        with the paper's claim or number beside them), ``figures`` (PNG paths relative to
        ``out_dir``), ``clusters_file`` (per "features/method/train" and ".../test", every
        frame's cluster) and ``timings`` (seconds per part).
    """
    from sim.dataset import load_dataset
    from sim.dataset import write_sequence as write_npz

    out = Path(out_dir)
    out.mkdir(parents=True, exist_ok=True)
    timings = {}
    start = time.perf_counter()
    synthetic, synthetic_labels = synthetic_rows(progress)
    timings["synthetic"] = time.perf_counter() - start
    start = time.perf_counter()
    dataset = load_dataset(dataset_dir)
    real, real_labels = real_rows(dataset, progress, n_clusters)
    timings["real"] = time.perf_counter() - start
    clusters = {}
    for row in real:
        key = f"{row['features']}/{row['method']}"
        clusters[f"{key}/train"] = np.asarray(row.pop("train_labels"))
        clusters[f"{key}/test"] = np.asarray(row.pop("test_labels"))
    write_npz(out / CLUSTERS_FILE, clusters)
    figures = [
        plot_labels(synthetic_labels, out / "synthetic_labels.png", "point index"),
        plot_labels(real_labels, out / "real_labels.png", "test frame index"),
    ]
    result = {
        "synthetic": synthetic,
        "real": real,
        "figures": [str(p.relative_to(out)) for p in figures],
        "clusters_file": CLUSTERS_FILE,
        "ground_truth": dataset.has_ground_truth,
        "timings": timings,
        "settings": {
            "synthetic": {"K": SYNTHETIC_K, "Q": SYNTHETIC_Q},
            "real": {
                "K": real[0]["K"],
                "Q": real[0]["Q"],
                "split": "even frames train, odd frames test",
            },
            "dataset": str(dataset_dir),
        },
    }
    atomic_write_bytes(out / "results.json", (json.dumps(result, indent=2) + "\n").encode())
    return result


def markdown_tables(result: dict) -> str:
    """Format the two tables of ``docs/guides/manifold-clustering.md`` from a `reproduce` result.

    Parameters
    ----------
    result : dict
        The result of `reproduce`.

    Returns
    -------
    str
        The markdown.
    """
    lines = ["| set | method | error | paper's claim |", "|---|---|---|---|"]
    for r in result["synthetic"]:
        lines.append(f"| {r['set']} | {r['method']} | {r['error']:.3f} | {r['paper_claim']} |")
    lines += [""] + ([] if result.get("ground_truth", True) else [NO_LABELS, ""])
    lines += ["| features | method | train error | test error | paper |", "|---|---|---|---|---|"]

    def pct(value):
        return "--" if value is None else f"{value:.1%}"

    for r in result["real"]:
        lines.append(
            f"| {r['features']} | {r['method']} | {pct(r['train_error'])} | "
            f"{pct(r['test_error'])} | {pct(r['paper_error'])} |"
        )
    return "\n".join(lines)


def build_parser(parser: argparse.ArgumentParser | None = None) -> argparse.ArgumentParser:
    """Build the command line of ``topomap reproduce``.

    Parameters
    ----------
    parser : argparse.ArgumentParser, optional
        The parser to add the arguments to; a new one by default.

    Returns
    -------
    argparse.ArgumentParser
        The parser.
    """
    parser = parser or argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--data", required=True, help="dataset directory (topomap collect)")
    parser.add_argument("--out", required=True, help="directory for results.json and plots")
    parser.add_argument("--json", action="store_true", help="print the results as JSON")
    parser.add_argument(
        "--clusters",
        type=int,
        default=None,
        help=f"K on the dataset (default {REAL_K}, the paper's; for your own data)",
    )
    return parser


def run(args) -> int:
    """Run ``topomap reproduce`` and print its tables (or JSON).

    Parameters
    ----------
    args : argparse.Namespace
        The command line of ``build_parser``.

    Returns
    -------
    int
        The exit status, 0.
    """
    result = reproduce(args.data, args.out, n_clusters=args.clusters)
    print(json.dumps(result, indent=2) if args.json else markdown_tables(result))
    return 0


def main(argv: list[str] | None = None) -> int:
    """Run the command line ``python -m scripts.manifold.reproduce``.

    Parameters
    ----------
    argv : list of str, optional
        The arguments; ``sys.argv[1:]`` by default.

    Returns
    -------
    int
        The exit status, 0.
    """
    return run(build_parser().parse_args(argv))


if __name__ == "__main__":
    raise SystemExit(main())
