"""Where the wall time of one graph-path fit goes, phase by phase.

Fits ``ManifoldClustering(8, 35, n_jobs=J)`` on the speed benchmark's draw (8 branching
sequences, n points, d = 2000) twice in one process (the second fit finds the worker
processes started) and prints, per fit, when each phase ran: the k-NN graph, every level of
the tree's split searches (with its nodes' sizes), the combination and eq. 13's cluster
models. Run it once with ``--n-jobs 1`` and once with ``--n-jobs 2``: the one-process phases
bound what two cores can do (docs/guides/manifold-clustering.md)::

    python -m experiments.manifold.fit_timeline --n 2400 --n-jobs 2
"""

from __future__ import annotations

import argparse
import os
import time

import numpy as np

import mapping.manifold.clustering as manifold_module
import mapping.manifold.geometry as geometry_module
from mapping.manifold import ManifoldClustering, branching_sequences

_PHASES = (
    (geometry_module, "knn_edges"),
    (manifold_module, "combine_tree"),
    (manifold_module, "cluster_model"),
)


def _timed(module, name: str, log: list) -> None:
    """Replace ``module.name`` by a wrapper that appends (name, start, end, detail) to log."""
    inner = getattr(module, name)

    def wrapper(*args, **kwargs):
        start = time.perf_counter()
        out = inner(*args, **kwargs)
        log.append((name, start, time.perf_counter(), ""))
        return out

    setattr(module, name, wrapper)


def _timed_levels(log: list) -> None:
    """Every call of ``best_splits`` (one level of the tree) with its nodes' sizes."""
    import mapping.manifold.tree as tree_module

    inner = tree_module.best_splits

    def wrapper(nodes, *args, **kwargs):
        start = time.perf_counter()
        out = inner(nodes, *args, **kwargs)
        if not nodes:
            return out
        sizes = ", ".join(str(node.size) for node in nodes)
        log.append(("split level", start, time.perf_counter(), f"nodes of {sizes}"))
        return out

    tree_module.best_splits = wrapper


def main(argv=None) -> None:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--n", type=int, default=2400, help="points (a multiple of 8)")
    p.add_argument("--n-jobs", type=int, default=2, help="ManifoldClustering's n_jobs")
    a = p.parse_args(argv)
    if a.n < 8 or a.n % 8:
        p.error(f"--n must be a positive multiple of 8, got {a.n}")
    log: list = []
    for module, name in _PHASES:
        _timed(module, name, log)
    _timed_levels(log)
    X, _ = branching_sequences(a.n // 8, 2000, np.random.default_rng(1))
    print(
        f"n = {a.n}, n_jobs = {a.n_jobs}, os.cpu_count() = {os.cpu_count()}, "
        f"load average {os.getloadavg()[0]:.1f}"
    )
    for fit in (1, 2):
        log.clear()
        start = time.perf_counter()
        ManifoldClustering(8, 35, n_jobs=a.n_jobs).fit(X)
        total = time.perf_counter() - start
        print(f"\nfit {fit}: {total:.2f} s\n")
        print("| phase | from | to | seconds | |\n|---|---|---|---|---|")
        models = [row for row in log if row[0] == "cluster_model"]
        rows = [row for row in log if row[0] != "cluster_model"]
        if models:
            rows.append(("cluster models", models[0][1], models[-1][2], f"{len(models)} clusters"))
        for name, t0, t1, detail in sorted(rows, key=lambda row: row[1]):
            print(f"| {name} | {t0 - start:.2f} | {t1 - start:.2f} | {t1 - t0:.2f} | {detail} |")


if __name__ == "__main__":
    main()
