"""The dev-seed sweep behind "The graph path on the images" (docs/guides/manifold-clustering.md).

Graph path (``kernel="sparse"``) settings against the dense path on the 8-manifold images of
the dev dataset seeds (HSV histograms, K = 8, Q = 35, the paper's split). Every setting is
fitted on each seed's features as they are and on ``--draws - 1`` copies multiplied by
``1 + 1e-12 N(0, 1)``; the mean train / test error, the tree's majority-merge bound and the
number of seeds whose draws gave different errors are printed. Without the split's near-tie
tolerance the trees are chaotic on these images (round-off decides near-ties of eq. 8, 10 and
12; ``--tie 0`` brings that back) and the draws average that out; with it, one draw per seed
is enough.

Settings that are not options of ``ManifoldClustering`` are made here by patching module
constants and functions for the duration of one setting (diagnosis only)::

    python -m experiments.manifold.graph_path ROOT --seeds 0 100 101 102 103 --draws 3

``--where`` instead prints where the two paths part on the same fits: whether
the root splits put the points on the same sides, and each tree's leaves combined in each
path's kernel (the combination's kernel swapped); ``--sensitivity SEED`` searches one
sub-node of the dense tree twice, on its block of the full distance matrix and on its
distances recomputed from its points (equal to ~1e-14), both on one BLAS thread as in
``fit``.

ROOT holds ``m-data-S`` (``topomap collect --world all --seed S --out ROOT/m-data-S``).
Use dev seeds only: fresh seeds are for the frozen rule (``python -m
experiments.manifold.dense_vs_graph --graph-vs-dense``).
"""

from __future__ import annotations

import argparse
import contextlib
from dataclasses import replace
from pathlib import Path

import numpy as np

import mapping.manifold.geometry as geometry
import mapping.manifold.split as split_module
from common.blas import single_threaded_blas
from experiments.manifold.dense_vs_graph import add_tie_option, image_split
from mapping.distances import squared_distances
from mapping.manifold import ManifoldClustering
from mapping.manifold.geometry import DenseGeometry, training_geometry
from mapping.manifold.split import best_split
from mapping.manifold.tree import combine_tree
from mapping.metrics import clustering_error, majority_merge_error


def _full_sub(self, idx):
    """Dense sub-nodes of a graph fit searched as on the dense path (16 sigmas + Brent)."""
    idx = np.asarray(idx)
    if idx.shape[0] <= self.dense_below:
        return geometry.DenseGeometry(self.block(idx), coarse=False)
    return self.node(idx)


def _six_sigmas(space):
    """The graph path's former split search: 6 sigmas (the combination keeps 16)."""
    return replace(space, n_sigmas=min(space.n_sigmas, 6), refine_sigma=False)


def _capped_bounds(self):
    """sigma's upper bound on a graph node: the median over points of their longest edge."""
    lo, hi = _GRAPH_BOUNDS(self)
    E = self.edges
    has = np.diff(E.indptr) > 0
    longest = np.maximum.reduceat(np.sqrt(E.data), E.indptr[:-1][has])
    return lo, min(hi, float(np.median(longest)))


_GRAPH_BOUNDS = geometry.GraphGeometry.sigma_bounds
_SPARSE = {"kernel": "sparse"}
# name -> (ManifoldClustering settings, patches as (object, attribute, value)). The tables
# measured on a 6-sigma split search (some with a 6-sigma combination) came from this file at
# commit 69b317b, where the names meant that base.
SETTINGS = {
    "dense": ({"kernel": "dense"}, []),
    "graph": (_SPARSE, []),
    "graph, 6 sigmas per split (the former default)": (
        _SPARSE,
        [(geometry, "coarse_space", _six_sigmas)],
    ),
    "graph, dense sub-nodes searched fully": (
        _SPARSE,
        [(geometry.GraphGeometry, "sub", _full_sub)],
    ),
    "graph, n_neighbors = Q = 35": ({**_SPARSE, "n_neighbors": 35}, []),
    "graph, sigma capped at the median longest edge": (
        _SPARSE,
        [(geometry.GraphGeometry, "sigma_bounds", _capped_bounds)],
    ),
    "graph, n_components = 32": ({**_SPARSE, "n_components": 32}, []),
    "graph, n_components = 128": ({**_SPARSE, "n_components": 128}, []),
    "graph, n_components = 225": ({**_SPARSE, "n_components": 225}, []),
}


@contextlib.contextmanager
def _patched(patches):
    saved = [(obj, name, getattr(obj, name)) for obj, name, _ in patches]
    try:
        for obj, name, value in patches:
            setattr(obj, name, value)
        yield
    finally:
        for obj, name, value in saved:
            setattr(obj, name, value)


def sweep(root: Path, seeds: list[int], draws: int, names: list[str]) -> None:
    data = {s: image_split(root / f"m-data-{s}") for s in seeds}
    print("| setting | train | test | tree's bound | seeds whose draws differ |")
    print("|---|---|---|---|---|")
    for name in names:
        kwargs, patches = SETTINGS[name]
        rows = []
        with _patched(patches):
            for X_train, y_train, X_test, y_test in data.values():
                for draw in range(draws):
                    noise = np.random.default_rng(draw).standard_normal(X_train.shape)
                    X = X_train if draw == 0 else X_train * (1.0 + 1e-12 * noise)
                    model = ManifoldClustering(8, 35, **kwargs).fit(X)
                    rows.append(
                        (
                            clustering_error(y_train, model.labels_),
                            clustering_error(y_test, model.predict(X_test)),
                            majority_merge_error(y_train, model.leaf_labels_),
                        )
                    )
        train, test, bound = np.mean(rows, axis=0)
        per_seed = np.reshape(rows, (len(data), draws, 3))
        moved = int(np.sum(np.ptp(per_seed, axis=1).max(axis=1) > 0))
        print(
            f"| {name} | {train:.3f} | {test:.3f} | {bound:.3f} | {moved} of {len(data)} |",
            flush=True,
        )


def _draws(root: Path, seeds: list[int], draws: int):
    for seed in seeds:
        X_train, y_train, _, _ = image_split(root / f"m-data-{seed}")
        for draw in range(draws):
            noise = np.random.default_rng(draw).standard_normal(X_train.shape)
            yield seed, draw, (X_train if draw == 0 else X_train * (1.0 + 1e-12 * noise)), y_train


def where(root: Path, seeds: list[int], draws: int) -> None:
    """Root partitions compared, and each tree combined in each path's kernel."""
    print(
        "| seed | draw | points on other sides of the root | dense tree: dense / graph "
        "combination | graph tree: dense / graph combination |\n|---|---|---|---|---|"
    )
    errs = []
    for seed, draw, X, y in _draws(root, seeds, draws):
        fits = {k: ManifoldClustering(8, 35, kernel=k).fit(X) for k in ("dense", "sparse")}
        sides = [set(fits[k].tree_.children[0].indices.tolist()) for k in ("dense", "sparse")]
        moved = min(len(sides[0] ^ sides[1]), X.shape[0] - len(sides[0] ^ sides[1]))
        space = fits["dense"]._search_space(X.shape[0])
        row = []
        for tree_of in ("dense", "sparse"):
            leaves = [leaf.indices for leaf in fits[tree_of].tree_.leaves()]
            for kernel in ("dense", "sparse"):
                geometry = training_geometry(X, kernel, 10, 64)
                with single_threaded_blas():
                    combo = combine_tree(fits[tree_of].tree_, geometry, 8, space, "spectral")
                labels = np.empty(X.shape[0], dtype=np.intp)
                for j, group in enumerate(combo.groups):
                    for c in group:
                        labels[leaves[c]] = j
                row.append(clustering_error(y, labels))
        errs.append(row)
        print(
            f"| {seed} | {draw} | {moved} | {row[0]:.3f} / {row[1]:.3f} | "
            f"{row[2]:.3f} / {row[3]:.3f} |",
            flush=True,
        )
    m = np.mean(errs, axis=0)
    print(f"| mean | | | {m[0]:.3f} / {m[1]:.3f} | {m[2]:.3f} / {m[3]:.3f} |")


def sensitivity(root: Path, seed: int) -> None:
    """Every split node of the dense tree searched on two copies of its distances that differ
    by ~1e-14: its block of the full matrix (as in ``fit``) and its distances recomputed from
    its points (as a graph fit's dense sub-node has them)."""
    X, y, _, _ = image_split(root / f"m-data-{seed}")
    model = ManifoldClustering(8, 35, kernel="dense").fit(X)
    space = model._search_space(X.shape[0])
    D = squared_distances(X)
    nodes = [model.tree_]
    while nodes:
        node = nodes.pop(0)
        if not node.children:
            continue
        nodes.extend(node.children)
        idx = node.indices
        block, recomputed = D[np.ix_(idx, idx)], squared_distances(X[idx])
        gap = np.abs(block - recomputed).max()
        with single_threaded_blas():
            splits = [best_split(DenseGeometry(sq), 35, space) for sq in (block, recomputed)]
        same = np.array_equal(splits[0].in_first, splits[1].in_first)
        same = same or np.array_equal(splits[0].in_first, ~splits[1].in_first)
        print(
            f"node of {idx.shape[0]} points (copies differ by <= {gap:.1e}): "
            + ("same split" if same else "DIFFERENT split")
        )
        for name, split in zip(("block", "recomputed"), splits, strict=True):
            sides = np.bincount(y[idx][split.in_first], minlength=8).tolist()
            print(
                f"  {name}: sigma {split.sigma:.4f}, alpha {split.alpha:.5f}, "
                f"Omega {split.omega:.4f}; p1 per manifold {sides}"
            )


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("root", type=Path)
    parser.add_argument("--seeds", type=int, nargs="+", default=[0, 100, 101, 102, 103])
    parser.add_argument("--draws", type=int, default=3)
    parser.add_argument("--settings", nargs="+", default=list(SETTINGS), choices=list(SETTINGS))
    parser.add_argument("--where", action="store_true", help="where the two paths part")
    parser.add_argument("--sensitivity", type=int, metavar="SEED", help="one node searched twice")
    add_tie_option(parser)
    args = parser.parse_args()
    split_module.TIE = args.tie
    if args.where:
        where(args.root, args.seeds, args.draws)
    elif args.sensitivity is not None:
        sensitivity(args.root, args.sensitivity)
    else:
        sweep(args.root, args.seeds, args.draws, args.settings)


if __name__ == "__main__":
    main()
