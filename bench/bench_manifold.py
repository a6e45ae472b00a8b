"""Benchmark of mapping.ManifoldClustering against its speed targets.

Run ``.venv/bin/python bench/bench_manifold.py`` for the timing table:

* fit of 600 points, K = 8, Q = 35, at d = 2000 and d = 230400 (a 320x240 RGB image);
* ``signal`` for one view toward a cluster centre and ``predict`` of one view (median of 50
  calls; ``--one-view`` prints only these and the fits they need);
* fit time for n = 300, 600, 1200, 2400 (d = 2000) beside sklearn's SpectralClustering.

``--scale [N ...]`` prints fit time against n (300 ... 10,000 by default) beside sklearn's
SpectralClustering as a ratio, with both clustering errors; ``--n-jobs J``
adds the graph fits with ``ManifoldClustering(n_jobs=J)``.

``--memory N [N ...]`` prints the peak memory of one such fit, ours and scikit-learn's, each
in a fresh process (numpy's allocations and the resident high-water mark); with ``--scale``
in the same call, after the timings.

The studies that compare the dense and graph kernels' accuracy and the readings of the paper's
ambiguous steps are ``python -m experiments.manifold.dense_vs_graph``.

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

from mapping.manifold import ManifoldClustering, branching_sequences
from mapping.metrics import clustering_error


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
    ``predict`` projects the view once for all clusters (``mapping.manifold.stacked_signal``)."""
    view = held_out[0]
    ranks = [m.basis.shape[0] for m in model._models]
    order = itertools.cycle(range(len(held_out)))  # each view once per timed pass
    rows = [
        (
            f"signal, one view, d={d}, projection_tol={tol:g}, cluster of "
            f"{np.sum(model.labels_ == 0)} (basis rank {ranks[0]})",
            lambda: model.signal(view, 0),
        ),
        (
            f"predict, one view, d={d}, projection_tol={tol:g}, K=8 (ranks {sum(ranks)})",
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
            delayed(importlib.import_module)("mapping.manifold") for _ in range(n_jobs)
        )

    print(
        f"os.cpu_count() = {os.cpu_count()}, usable {len(os.sched_getaffinity(0))}, "
        f"load average {os.getloadavg()[0]:.1f}"
    )
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
        theirs, theirs_cpu = wall_and_cpu(lambda X=X, sk=sk: sk.fit(X))
        err_sk = clustering_error(y, sk.labels_)
        kernels = ["auto"] + (["dense"] if n <= dense_up_to and n > 1000 else [])
        kernels += ["sparse"] if n <= 1000 else []
        runs = [(kernel, None) for kernel in kernels]
        runs += [("auto", n_jobs)] if n_jobs and n > 1000 else []
        for kernel, jobs in runs:
            model = ManifoldClustering(8, q, kernel=kernel, n_jobs=jobs)
            ours, ours_cpu = wall_and_cpu(lambda X=X, model=model: model.fit(X))
            label = kernel if jobs is None else f"{kernel}, n_jobs={jobs}"
            print(
                f"| {n} | {label} | {ours:.2f} s ({ours_cpu:.2f} s) | "
                f"{clustering_error(y, model.labels_):.3f} | {theirs:.2f} s ({theirs_cpu:.2f} s) "
                f"| {err_sk:.3f} | {ours / theirs:.1f} |",
                flush=True,
            )


def wall_and_cpu(fn) -> tuple[float, float]:
    """Wall-clock and CPU seconds (``time.process_time``: every thread) of one call."""
    wall, cpu = time.perf_counter(), time.process_time()
    fn()
    return time.perf_counter() - wall, time.process_time() - cpu


def _peak_child(method: str, n: int) -> tuple[float, float | None]:
    """One fit in a fresh process: numpy's peak (MiB, ``tracemalloc``, which numpy reports
    to) and, where Linux lets the high-water mark be reset, the peak resident memory above the
    start (every allocation: BLAS, LAPACK and scikit-learn's C buffers included)."""
    import tracemalloc

    from sklearn.cluster import SpectralClustering

    def status(key: str) -> float:
        with open("/proc/self/status") as f:
            return next(int(line.split()[1]) for line in f if line.startswith(key)) / 2**10

    X, _ = branching_sequences(n // 8, 2000, np.random.default_rng(1))
    if method == "ours":
        model = ManifoldClustering(8, min(35, n // 16))
    else:
        model = SpectralClustering(8, affinity="nearest_neighbors", n_neighbors=10, random_state=0)
    try:
        with open("/proc/self/clear_refs", "w") as f:
            f.write("5")  # resets VmHWM to the current resident size
        start = status("VmRSS")
    except OSError:
        start = None
    tracemalloc.start()
    model.fit(X)
    top = tracemalloc.get_traced_memory()[1]
    tracemalloc.stop()
    return top / 2**20, None if start is None else status("VmHWM") - start


def peak_memory(sizes: list[int]) -> None:
    """Peak memory of one fit beyond the data X (the graph path's target: O(n k + n m), not
    O(n^2)), ours and scikit-learn's SpectralClustering on the 10-NN graph, each fit in a
    fresh process (memory freed earlier in a process would hide a later fit's peak)."""
    import multiprocessing

    def mib(value) -> str:
        return "n/a" if value is None else f"{value:.0f} MiB"

    print(
        "\n| n | data X | ours fit peak: numpy (resident) | sklearn fit peak: numpy (resident) |"
        "\n|---|---|---|---|"
    )
    context = multiprocessing.get_context("spawn")
    for n in sizes:
        row = {}
        for method in ("ours", "sklearn"):
            with context.Pool(1) as pool:
                row[method] = pool.apply(_peak_child, (method, n))
        size = 8 * n * 2000 / 2**20
        print(
            f"| {n} | {size:.0f} MiB | {mib(row['ours'][0])} ({mib(row['ours'][1])}) | "
            f"{mib(row['sklearn'][0])} ({mib(row['sklearn'][1])}) |",
            flush=True,
        )


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--quick", action="store_true", help="small sizes only")
    parser.add_argument(
        "--one-view", action="store_true", help="fit and one-view signal/predict rows only"
    )
    parser.add_argument(
        "--scale",
        type=int,
        nargs="*",
        metavar="N",
        help="fit time against n beside sklearn instead (default sizes 300 ... 10000)",
    )
    parser.add_argument(
        "--memory", type=int, nargs="+", metavar="N", help="peak memory of a fit of N points"
    )
    parser.add_argument(
        "--dense-up-to", type=int, default=1200, help="with --scale: also time kernel='dense'"
    )
    parser.add_argument(
        "--n-jobs", type=int, default=0, help="with --scale: also the graph fits with n_jobs"
    )
    args = parser.parse_args()
    if args.scale is not None:
        scaling(args.scale or [300, 600, 1200, 2400, 5000, 10000], args.dense_up_to, args.n_jobs)
    if args.memory:
        peak_memory(args.memory)
    if args.scale is None and not args.memory:
        timings(args.quick, args.one_view)


if __name__ == "__main__":
    main()
