"""Benchmark of mapping.ManifoldClustering (issue 3 speed targets) and its ambiguity experiments.

Run ``.venv/bin/python bench/bench_manifold.py`` for the timing table:

* fit of 600 points, K = 8, Q = 35, at d = 2000 and d = 230400 (a 320x240 RGB image);
* ``signal`` for one view toward a cluster centre and ``predict`` of one view (median of 50
  calls; ``--one-view`` prints only these and the fits they need);
* fit time for n = 300, 600, 1200, 2400 (d = 2000) beside sklearn's SpectralClustering.

``--scale [N ...]`` prints fit time against n (300 ... 10,000 by default) beside sklearn's
SpectralClustering as a ratio, with both clustering errors (issue 15 item 1); ``--n-jobs J``
adds the graph fits with ``ManifoldClustering(n_jobs=J)``.

``--memory N [N ...]`` prints the peak of numpy's allocations during one such fit.

``--sparse-accuracy [DATASET]`` prints the errors of kernel="sparse" against the dense path on
the synthetic sets and, given a dataset directory, on the 8-manifold images.

``--graph-vs-dense ROOT [--seeds S ...]`` prints, per protocol dataset ``ROOT/m-data-S``
(seeds 1-12 unless given, as ``python -m scripts.manifold_protocol`` collects them), both
paths' errors on the images, their means and the paired difference of the test errors with
bootstrap 95% intervals (issue 15 item 1).

``--pooled ROOT --seeds S ... [--pool 3]`` pools the training frames of each group of
``--pool`` seeds (n = 450 per seed) and compares the dense path with ``kernel="auto"`` (the
graph above 1000 points): what a user gets by default on a larger image set.

``--experiments`` instead prints the tables behind docs/manifold-clustering.md: clustering
error of each reading of the paper's ambiguous steps on the four synthetic sets (clean and
noisy) and on 8 branching sequences, with best-sigma NCut and self-tuning baselines.

The data are 8 smooth random curves in R^d shaped like the paper's image set: two "worlds",
each a trunk followed by three branches leaving its end at different speeds.
"""

from __future__ import annotations

import argparse
import importlib
import itertools
import os
import sys
import time
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

import mapping._manifold_split as split_module
from mapping._manifold_stack import Stack
from mapping.manifold import ManifoldClustering
from mapping.metrics import clustering_error
from mapping.synthetic import branching_sequences


def _time(fn, repeat: int = 1) -> float:
    best = np.inf
    for _ in range(repeat):
        start = time.perf_counter()
        fn()
        best = min(best, time.perf_counter() - start)
    return best


def _median_ms(fn, repeat: int = 50) -> tuple[float, float]:
    """Median wall and CPU milliseconds (``time.process_time``: all threads of the process) of
    ``repeat`` calls; on a shared machine the CPU time says what a call needed of the cores."""
    wall, cpu = [], []
    for _ in range(repeat):
        start, start_cpu = time.perf_counter(), time.process_time()
        fn()
        wall.append(time.perf_counter() - start)
        cpu.append(time.process_time() - start_cpu)
    return 1e3 * float(np.median(wall)), 1e3 * float(np.median(cpu))


def _one_view_timings(model: ManifoldClustering, held_out: np.ndarray, d: int, tol: float) -> None:
    """``signal`` and ``predict`` for one view (targets: 2 ms at 320x240x3, 0.5 ms at d=2000);
    ``predict`` projects the view once for all clusters (``mapping._manifold_stack``)."""
    view = held_out[0]
    ranks = [m.basis.shape[0] for m in model._models]
    # clusters whose bases a view is projected on (the others are beyond exp's underflow)
    stack = Stack.of(model._models)
    reached = stack.reachable(stack.projection(held_out)[1]).sum(axis=1)
    order = itertools.cycle(range(len(held_out)))  # each view once per timed pass
    rows = [
        (
            f"signal, one view, d={d}, projection_tol={tol:g}, cluster of "
            f"{np.sum(model.labels_ == 0)} (basis rank {ranks[0]})",
            lambda: model.signal(view, 0),
        ),
        (
            f"predict, one view, d={d}, projection_tol={tol:g}, K=8 (ranks {sum(ranks)}; "
            f"{reached.mean():.2f} clusters reached per held-out view, {reached[0]} by this one)",
            lambda: model.predict(view[None, :]),
            50,
        ),
        (
            f"predict, one view at a time, each of the {len(held_out)} held-out views, "
            f"d={d}, projection_tol={tol:g}",
            lambda: model.predict(held_out[next(order)][None, :]),
            len(held_out),
        ),
    ]
    rows[0] += (50,)
    for label, fn, repeat in rows:
        fn()  # the first predict builds the stack (once per fitted model)
        wall, cpu = _median_ms(fn, repeat)
        print(f"| {label} | {wall:.3f} ms ({cpu:.3f} ms CPU), median of {repeat} |")


def timings(quick: bool, one_view: bool = False) -> None:
    print(f"os.cpu_count() = {os.cpu_count()}")
    print(f"OPENBLAS_NUM_THREADS = {os.environ.get('OPENBLAS_NUM_THREADS', 'unset')}")
    print(f"load average at the start {os.getloadavg()[0]:.2f}")
    print("\n| case | time |\n|---|---|")
    for d in (2000,) if quick else (2000, 230_400):
        X, y = branching_sequences(150, d, np.random.default_rng(0))
        train = np.arange(len(X)) % 2 == 0
        model = ManifoldClustering(8, 35)
        t_fit = _time(lambda model=model, X=X, train=train: model.fit(X[train]))
        err_train = clustering_error(y[train], model.labels_)
        err_test = clustering_error(y[~train], model.predict(X[~train]))
        for tol in (0.0, 1e-4):
            if tol:
                model.set_params(projection_tol=tol).fit(X[train])
            _one_view_timings(model, X[~train], d, tol)
        print(
            f"| fit n=600 K=8 Q=35 d={d} | {t_fit:.2f} s (train err {err_train:.3f}, "
            f"test err {err_test:.3f}) |"
        )
    if one_view:
        print(f"\nload average at the end {os.getloadavg()[0]:.2f}")
        return

    from sklearn.cluster import SpectralClustering

    print("\n| n | ManifoldClustering fit | sklearn SpectralClustering |\n|---|---|---|")
    for n in (300, 600) if quick else (300, 600, 1200, 2400):
        X, _ = branching_sequences(n // 8, 2000, np.random.default_rng(1))
        q = min(35, n // 16)
        ours = _time(lambda X=X, q=q: ManifoldClustering(8, q).fit(X))
        sk = SpectralClustering(8, affinity="nearest_neighbors", n_neighbors=10, random_state=0)
        theirs = _time(lambda X=X, sk=sk: sk.fit(X))
        print(f"| {n} | {ours:.2f} s | {theirs:.2f} s |")


def scaling(sizes: list[int], dense_up_to: int, n_jobs: int = 0) -> None:
    """Fit time against n (d = 2000, K = 8, Q = min(35, n / 16)) beside scikit-learn's
    SpectralClustering on the same data, with the clustering error of each against the true
    sequences; ``kernel="auto"`` (dense up to 1000 points, the k-NN graph above), and the exact
    dense path as well up to ``dense_up_to`` points. With ``n_jobs``, the graph fits again
    with ``n_jobs`` worker processes, started before the first timing (a fresh process's
    first parallel fit also pays their start and imports, ~1.5 s on 2 cores); the CPU
    seconds are then the parent's only."""
    from joblib import Parallel, delayed
    from sklearn.cluster import SpectralClustering

    if n_jobs:  # start the workers and import the search there, as a second fit finds them
        Parallel(n_jobs=n_jobs)(
            delayed(importlib.import_module)("mapping._manifold_split") for _ in range(n_jobs)
        )

    print(f"os.cpu_count() = {os.cpu_count()}, load average {os.getloadavg()[0]:.1f}")
    # CPU seconds (all threads of the process) beside the wall time: on a shared machine the
    # wall time is mostly waiting; the CPU time bounds what the fit needs of the cores.
    print(
        "\n| n | kernel | ours fit (CPU) | err | sklearn fit (CPU) | err | ratio ours / sklearn |"
        "\n|---|---|---|---|---|---|---|"
    )
    for n in sizes:
        X, y = branching_sequences(n // 8, 2000, np.random.default_rng(1))
        q = min(35, n // 16)
        sk = SpectralClustering(8, affinity="nearest_neighbors", n_neighbors=10, random_state=0)
        theirs, theirs_cpu = _wall_and_cpu(lambda X=X, sk=sk: sk.fit(X))
        err_sk = clustering_error(y, sk.labels_)
        kernels = ["auto"] + (["dense"] if n <= dense_up_to and n > 1000 else [])
        kernels += ["sparse"] if n <= 1000 else []
        runs = [(kernel, None) for kernel in kernels]
        runs += [("auto", n_jobs)] if n_jobs and n > 1000 else []
        for kernel, jobs in runs:
            model = ManifoldClustering(8, q, kernel=kernel, n_jobs=jobs)
            ours, ours_cpu = _wall_and_cpu(lambda X=X, model=model: model.fit(X))
            label = kernel if jobs is None else f"{kernel}, n_jobs={jobs}"
            print(
                f"| {n} | {label} | {ours:.2f} s ({ours_cpu:.2f} s) | "
                f"{clustering_error(y, model.labels_):.3f} | {theirs:.2f} s ({theirs_cpu:.2f} s) "
                f"| {err_sk:.3f} | {ours / theirs:.1f} |",
                flush=True,
            )


def _wall_and_cpu(fn) -> tuple[float, float]:
    """Wall-clock and CPU seconds (``time.process_time``: every thread) of one call."""
    wall, cpu = time.perf_counter(), time.process_time()
    fn()
    return time.perf_counter() - wall, time.process_time() - cpu


def peak_memory(sizes: list[int]) -> None:
    """Peak of numpy's allocations during one fit (``tracemalloc``, which numpy reports to),
    beside the data itself, for the ``--scale`` data (issue 15: O(n k + n m), not O(n^2))."""
    import tracemalloc

    print("\n| n | data X | fit peak (beyond X) |\n|---|---|---|")
    for n in sizes:
        X, _ = branching_sequences(n // 8, 2000, np.random.default_rng(1))
        tracemalloc.start()
        ManifoldClustering(8, min(35, n // 16)).fit(X)
        peak = tracemalloc.get_traced_memory()[1]
        tracemalloc.stop()
        print(f"| {n} | {X.nbytes / 2**20:.0f} MiB | {peak / 2**20:.0f} MiB |", flush=True)


def _image_split(dataset) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
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
    from scripts.manifold_methods import bootstrap_mean

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
    from scripts.manifold_diagnosis import majority_merge_error

    print("| seed | dense train / test (tree's bound) | graph train / test (tree's bound) |")
    print("|---|---|---|")
    tests: dict[str, list[float]] = {"dense": [], "sparse": []}
    for seed in seeds:
        X_train, y_train, X_test, y_test = _image_split(Path(root) / f"m-data-{seed}")
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
        parts = [_image_split(Path(root) / f"m-data-{seed}") for seed in pool]
        X_train, y_train, X_test, y_test = (np.concatenate(p) for p in zip(*parts, strict=True))
        cells = []
        for kernel in ("dense", "auto"):
            model = ManifoldClustering(8, 35, kernel=kernel)
            wall, _ = _wall_and_cpu(lambda model=model, X=X_train: model.fit(X))
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
    from mapping.synthetic import SYNTHETIC_SETS

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
    X_train, y_train, X_test, y_test = _image_split(dataset)
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
    from mapping.baselines import SelfTuningSpectralClustering
    from mapping.sigma_sweep import best_sigma_ncut
    from mapping.synthetic import make_all

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
    ``mapping._manifold_split.TIE`` (0: ties decided by round-off, the code before session 18)."""
    parser.add_argument(
        "--tie", type=float, default=split_module.TIE,
        help="near-tie tolerance of the split's choices (0: ties decided by round-off, the "
        "code before session 18)",
    )  # fmt: skip


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--quick", action="store_true", help="small sizes only")
    parser.add_argument("--experiments", action="store_true", help="ambiguity tables instead")
    parser.add_argument(
        "--one-view", action="store_true", help="fit and one-view signal/predict rows only"
    )
    parser.add_argument(
        "--scale", type=int, nargs="*", metavar="N",
        help="fit time against n beside sklearn instead (default sizes 300 ... 10000)",
    )  # fmt: skip
    parser.add_argument(
        "--memory", type=int, nargs="+", metavar="N", help="peak memory of a fit of N points"
    )
    parser.add_argument(
        "--dense-up-to", type=int, default=1200, help="with --scale: also time kernel='dense'"
    )
    parser.add_argument(
        "--sparse-accuracy", nargs="?", const="", metavar="DATASET",
        help="kernel='sparse' against 'dense' on the synthetic sets (and a dataset's images)",
    )  # fmt: skip
    parser.add_argument(
        "--graph-vs-dense", metavar="ROOT", help="both paths on the protocol's fresh image seeds"
    )
    parser.add_argument(
        "--seeds", type=int, nargs="+", default=list(range(1, 13)),
        help="with --graph-vs-dense: the dataset seeds (default 1-12); with --pooled: the "
        "seeds, pooled in consecutive groups of --pool",
    )  # fmt: skip
    parser.add_argument(
        "--pooled", metavar="ROOT", help="dense against 'auto' on several seeds' frames pooled"
    )
    parser.add_argument("--pool", type=int, default=3, help="with --pooled: seeds per pool")
    parser.add_argument(
        "--n-jobs", type=int, default=0, help="with --scale: also the graph fits with n_jobs"
    )
    add_tie_option(parser)
    args = parser.parse_args()
    split_module.TIE = args.tie
    if args.memory:
        peak_memory(args.memory)
    elif args.graph_vs_dense:
        graph_vs_dense(args.graph_vs_dense, args.seeds)
    elif args.pooled:
        seeds = args.seeds
        pooled(args.pooled, [seeds[i : i + args.pool] for i in range(0, len(seeds), args.pool)])
    elif args.sparse_accuracy is not None:
        sparse_accuracy(args.sparse_accuracy or None)
    elif args.scale is not None:
        scaling(args.scale or [300, 600, 1200, 2400, 5000, 10000], args.dense_up_to, args.n_jobs)
    else:
        experiments() if args.experiments else timings(args.quick, args.one_view)


if __name__ == "__main__":
    main()
