"""The manifold method's two kernels (dense and k-NN graph) against each other, and the
readings of the paper's ambiguous steps, on synthetic sets and the protocol's image seeds.

    python -m experiments.manifold.dense_vs_graph --graph-vs-dense ROOT [--seeds S ...]
    python -m experiments.manifold.dense_vs_graph --pooled ROOT --seeds S ... [--pool 3]
    python -m experiments.manifold.dense_vs_graph --sparse-accuracy [DATASET]
    python -m experiments.manifold.dense_vs_graph --experiments

``--graph-vs-dense`` prints, per protocol dataset ``ROOT/m-data-S`` (seeds 1-12 unless
given, as ``python -m scripts.manifold.protocol`` collects them), both paths' errors on the
images, their means and the paired difference of the test errors with bootstrap 95%
intervals. ``--pooled`` pools the training frames of each group of ``--pool`` seeds and
compares the dense path with ``kernel="auto"``. ``--sparse-accuracy`` prints the errors of
kernel="sparse" against the dense path on the synthetic sets (and a dataset's images).
``--experiments`` prints the clustering error of each reading of the paper's ambiguous steps
on the four synthetic sets (clean and noisy) and on 8 branching sequences, with best-sigma
NCut and self-tuning baselines.
"""

from __future__ import annotations

import argparse
import os
from pathlib import Path

import numpy as np

import mapping.manifold.split as split_module
from bench.bench_manifold import wall_and_cpu
from mapping.manifold import ManifoldClustering, branching_sequences
from mapping.metrics import clustering_error, majority_merge_error


def image_split(dataset) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """HSV histograms of a dataset's paper split: X_train, y_train, X_test, y_test."""
    from mapping import ColorHistogramFeatures
    from sim.dataset import load_dataset

    data = load_dataset(dataset)
    train, test = data.paper_split()
    y, images = data.concat("labels"), data.concat("images")
    features = ColorHistogramFeatures()
    X_train, X_test = features.fit_transform(images[train]), features.transform(images[test])
    return X_train, y[train], X_test, y[test]


def _paired_summary(errs: dict[str, list[float]], names: tuple[str, str]) -> None:
    """Mean test error of each path with its bootstrap 95% interval, and the paired difference
    (second minus first) with its interval and the count of worse / better / tied."""
    from scripts.manifold import bootstrap_mean

    for name in names:
        b = bootstrap_mean(errs[name], np.random.default_rng(0))
        print(f"{name}, test error: {b['mean']:.3f} [{b['lo']:.3f}, {b['hi']:.3f}] (n={b['n']})")
    diffs = np.subtract(errs[names[1]], errs[names[0]])
    d = bootstrap_mean(diffs, np.random.default_rng(0))
    print(
        f"{names[1]} - {names[0]}, test error: {d['mean']:+.3f} [{d['lo']:+.3f}, {d['hi']:+.3f}];"
        f" worse on {int(np.sum(diffs > 0))}, better on {int(np.sum(diffs < 0))}, "
        f"tied on {int(np.sum(diffs == 0))} of {diffs.size}"
    )


def graph_vs_dense(root: str, seeds=range(1, 13)) -> None:
    """The graph path (``kernel="sparse"``) against the dense path on the 8-manifold images of
    fresh dataset seeds (K = 8, Q = 35, default settings otherwise): per-seed train / test
    errors, each path's mean test error and the paired difference with bootstrap 95% intervals."""
    print(f"load average {os.getloadavg()[0]:.1f}")

    print("| seed | dense train / test (tree's bound) | graph train / test (tree's bound) |")
    print("|---|---|---|")
    tests: dict[str, list[float]] = {"dense": [], "sparse": []}
    for seed in seeds:
        X_train, y_train, X_test, y_test = image_split(Path(root) / f"m-data-{seed}")
        errs = {}
        for kernel in ("dense", "sparse"):
            model = ManifoldClustering(8, 35, kernel=kernel).fit(X_train)
            errs[kernel] = (
                clustering_error(y_train, model.labels_),
                clustering_error(y_test, model.predict(X_test)),
                majority_merge_error(y_train, model.leaf_labels_),
            )
            tests[kernel].append(errs[kernel][1])
        cells = " | ".join(f"{a:.3f} / {b:.3f} ({c:.3f})" for a, b, c in errs.values())
        print(f"| {seed} | {cells} |", flush=True)
    print(f"\nload average {os.getloadavg()[0]:.1f}")
    _paired_summary(tests, ("dense", "sparse"))


def pooled(root: str, pools: list[list[int]]) -> None:
    """What ``kernel="auto"`` gives above 1000 frames: the training frames of several dataset
    seeds pooled (n = 450 per seed), fitted by the dense path and by "auto" (the graph path
    above 1000), K = 8, Q = 35; test frames: those seeds' odd frames. Per pool the train / test
    errors and fit times, then both paths' means and the paired difference."""
    print(f"load average {os.getloadavg()[0]:.1f}")
    print("| seeds | n | dense train / test (fit) | auto train / test (fit) |\n|---|---|---|---|")
    tests: dict[str, list[float]] = {"dense": [], "auto": []}
    for pool in pools:
        parts = [image_split(Path(root) / f"m-data-{seed}") for seed in pool]
        X_train, y_train, X_test, y_test = (np.concatenate(p) for p in zip(*parts, strict=True))
        cells = []
        for kernel in ("dense", "auto"):
            model = ManifoldClustering(8, 35, kernel=kernel)
            wall, _ = wall_and_cpu(lambda model=model, X=X_train: model.fit(X))
            err = clustering_error(y_test, model.predict(X_test))
            tests[kernel].append(err)
            train = clustering_error(y_train, model.labels_)
            cells.append(f"{train:.3f} / {err:.3f} ({wall:.1f} s)")
        seeds = ",".join(map(str, pool))
        print(f"| {seeds} | {X_train.shape[0]} | {cells[0]} | {cells[1]} |", flush=True)
    print(f"\nload average {os.getloadavg()[0]:.1f}")
    _paired_summary(tests, ("dense", "auto"))


def sparse_accuracy(dataset: str | None) -> None:
    """Clustering error of kernel="sparse" against the dense reference: the paper's synthetic
    sets (K = 3, Q = 20) and, given a dataset directory (``topomap collect --world all``), the
    8-manifold images as HSV histograms (K = 8, Q = 35, paper split; train / test error)."""
    from mapping.manifold import SYNTHETIC_SETS

    settings = [{"kernel": "dense"}] + [{"kernel": "sparse", "n_components": r} for r in (64, 16)]
    print("| kernel | " + " | ".join(SYNTHETIC_SETS) + " |")
    print("|---" * (len(SYNTHETIC_SETS) + 1) + "|")
    for kw in settings:
        errs = [
            clustering_error(y, ManifoldClustering(3, 20, **kw).fit(X).labels_)
            for X, y in (make() for make in SYNTHETIC_SETS.values())
        ]
        print(f"| {kw} | " + " | ".join(f"{e:.3f}" for e in errs) + " |", flush=True)
    if dataset is None:
        return
    X_train, y_train, X_test, y_test = image_split(dataset)
    print("\n| kernel | train error | test error |\n|---|---|---|")
    graphs = [{"kernel": "sparse", "n_neighbors": k} for k in (10, 30, 60)]
    for kw in [{"kernel": "dense"}, *graphs]:
        model = ManifoldClustering(8, 35, **kw).fit(X_train)
        print(
            f"| {kw} | {clustering_error(y_train, model.labels_):.3f} | "
            f"{clustering_error(y_test, model.predict(X_test)):.3f} |",
            flush=True,
        )


def experiments() -> None:
    from mapping.baselines import SelfTuningSpectralClustering, best_sigma_ncut
    from mapping.manifold import make_all

    variants = {
        "chosen (merge)": {},
        "combine=cut": {"combine": "cut"},
        "eq. 9 as printed": {"omega_sign": "printed"},
        "eq. 12 as printed": {"seed_rule": "printed"},
    }
    data = {"clean": make_all()}
    for seed in (0, 1):
        data[f"noise .002 #{seed}"] = make_all(noise=0.002, rng=np.random.default_rng(seed))
    names = list(data["clean"])
    print("| variant | data | " + " | ".join(names) + " |")
    print("|---" * (len(names) + 2) + "|")
    for label, options in variants.items():
        for dname, sets in data.items():
            errs = [
                clustering_error(y, ManifoldClustering(3, 20, **options).fit_predict(X))
                for X, y in sets.values()
            ]
            print(f"| {label} | {dname} | " + " | ".join(f"{e:.3f}" for e in errs) + " |")
    for dname, sets in data.items():
        ncut = [best_sigma_ncut(X, y, 3).error for X, y in sets.values()]
        st = [
            clustering_error(y, SelfTuningSpectralClustering(3).fit_predict(X))
            for X, y in sets.values()
        ]
        print(f"| best-sigma NCut | {dname} | " + " | ".join(f"{e:.3f}" for e in ncut) + " |")
        print(f"| self-tuning | {dname} | " + " | ".join(f"{e:.3f}" for e in st) + " |")

    print("\n8 branching sequences, d=500, train on even / test on odd frames, K=8, Q=35")
    print("| variant | train error | test error |\n|---|---|---|")
    X, y = branching_sequences(150, 500, np.random.default_rng(0))
    train = np.arange(len(X)) % 2 == 0
    for label, options in {
        **variants,
        "normalize=none": {"normalize": "none"},
        "predict_alpha=alpha_j": {"predict_alpha": None},
    }.items():
        model = ManifoldClustering(8, 35, **options).fit(X[train])
        print(
            f"| {label} | {clustering_error(y[train], model.labels_):.3f} | "
            f"{clustering_error(y[~train], model.predict(X[~train])):.3f} |"
        )
    sweep = best_sigma_ncut(X[train], y[train], 8)
    print(
        f"| best-sigma NCut (sigma={sweep.sigma:.3g}) | {sweep.error:.3f} | "
        f"{clustering_error(y[~train], sweep.model.predict(X[~train])):.3f} |"
    )


def add_tie_option(parser: argparse.ArgumentParser) -> None:
    """``--tie``: the near-tie tolerance of the split's choices, to set as
    ``mapping.manifold.split.TIE`` (0: ties decided by round-off, as before the tolerance
    existed)."""
    parser.add_argument(
        "--tie",
        type=float,
        default=split_module.TIE,
        help="near-tie tolerance of the split's choices (0: ties decided by round-off, as "
        "before the tolerance existed)",
    )


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--experiments", action="store_true", help="ambiguity tables")
    parser.add_argument(
        "--sparse-accuracy",
        nargs="?",
        const="",
        metavar="DATASET",
        help="kernel='sparse' against 'dense' on the synthetic sets (and a dataset's images)",
    )
    parser.add_argument(
        "--graph-vs-dense", metavar="ROOT", help="both paths on the protocol's fresh image seeds"
    )
    parser.add_argument(
        "--seeds",
        type=int,
        nargs="+",
        default=list(range(1, 13)),
        help="with --graph-vs-dense: the dataset seeds (default 1-12); with --pooled: the "
        "seeds, pooled in consecutive groups of --pool",
    )
    parser.add_argument(
        "--pooled", metavar="ROOT", help="dense against 'auto' on several seeds' frames pooled"
    )
    parser.add_argument("--pool", type=int, default=3, help="with --pooled: seeds per pool")
    add_tie_option(parser)
    args = parser.parse_args()
    split_module.TIE = args.tie
    if args.graph_vs_dense:
        graph_vs_dense(args.graph_vs_dense, args.seeds)
    elif args.pooled:
        seeds = args.seeds
        pooled(args.pooled, [seeds[i : i + args.pool] for i in range(0, len(seeds), args.pool)])
    elif args.sparse_accuracy is not None:
        sparse_accuracy(args.sparse_accuracy or None)
    elif args.experiments:
        experiments()
    else:
        parser.print_help()


if __name__ == "__main__":
    main()
