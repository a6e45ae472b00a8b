"""Why ours loses to scikit-learn's 10-NN graph on the branching sequences.

The sequences of `mapping.manifold.branching_sequences` are two stars: per world a trunk
and three branches that all start at the trunk's end. For each draw this script fits
``ManifoldClustering`` and asks where its error comes from:

* **the tree or the combination**: the error, the majority-merge bound of the leaves (the best
  any combining of them can do) and scikit-learn's error beside them;
* **the combination's sigma or its cut**: the spectral cut of the leaves (ambiguity 4,
  ``mapping.manifold.spectral_combine``) redone at every grid sigma and every grid alpha; if
  even the best of them misses the bound, no choice of (sigma, alpha) rescues the cut;
* **the cut's objective**: the normalised cut, in the leaves' kernel affinity where the cut
  was made, of the leaves' majority grouping (the bound) against the chosen grouping; if the
  bound's is larger, the objective itself prefers the wrong grouping;
* **the junction in the kernel**: for each branch's first leaf (the leaf holding most of the
  branch's first ``Q`` points), its largest mean kernel affinity to a leaf of another manifold
  over that to another leaf of its own; a ratio above 1 means the kernel ties the start of a
  branch to the other arms of the junction more than to the rest of its own arm.

Usage::

    python -m experiments.manifold.branching_diagnosis --n 600 1200 2400 --draws 0 1 2 3 4 [--out
    F.json]
"""

from __future__ import annotations

import argparse
import json
from pathlib import Path

import numpy as np
from sklearn.metrics import adjusted_rand_score

from common.fileio import atomic_write_bytes
from experiments.manifold.split_manifold import normalised_cut
from mapping import ManifoldClustering, clustering_error
from mapping.baselines.label_free import KNNSpectralClustering
from mapping.manifold import branching_sequences
from mapping.manifold.geometry import training_geometry
from mapping.manifold.spectral_combine import spectral_groups
from mapping.manifold.tree import GroupScores
from mapping.metrics import majority_merge_error

K, D = 8, 2000
#: labels of the trunks in `mapping.manifold.branching_sequences` (0..3 world one)
TRUNKS = (0, 4)


def branch_start_ratios(
    y: np.ndarray, leaves: list[np.ndarray], mean_affinity: np.ndarray, per_sequence: int, Q: int
) -> list[float]:
    """For each branch's first leaf: its largest mean affinity to a leaf of another majority
    manifold over its largest to another leaf of its own (inf if it has no other own leaf)."""
    majority = np.array([np.bincount(y[idx]).argmax() for idx in leaves])
    leaf_of = np.empty(len(y), dtype=np.intp)
    for c, idx in enumerate(leaves):
        leaf_of[idx] = c
    ratios = []
    for label in np.unique(y):
        if label in TRUNKS:
            continue
        first = label * per_sequence + np.arange(min(Q, per_sequence))
        b = int(np.bincount(leaf_of[first]).argmax())
        others = np.flatnonzero(majority != label)
        own = np.setdiff1d(np.flatnonzero(majority == label), [b])
        across = mean_affinity[b, others].max() if others.size else 0.0
        along = mean_affinity[b, own].max() if own.size else 0.0
        ratios.append(float(across / along) if along > 0 else float("inf"))
    return ratios


def diagnose(n: int, draw: int, Q: int = 35, every_alpha: bool = True) -> dict:
    """One draw of ``n`` points (n / 8 per sequence): the quantities of the module docstring
    (the cut redone at every grid alpha, or at the top alpha only if not ``every_alpha``)."""
    per_sequence = n // K
    X, y = branching_sequences(per_sequence, D, np.random.default_rng(draw))
    model = ManifoldClustering(K, Q).fit(X)
    L = model.leaf_labels_
    leaves = [np.flatnonzero(L == c) for c in range(int(L.max()) + 1)]
    geometry = training_geometry(X, model.kernel, model.n_neighbors, model.n_components)
    scores = GroupScores(geometry, leaves, model._search_space(n))
    majority = np.array([np.bincount(y[idx]).argmax() for idx in leaves])

    top = scores.M.shape[1] - 1  # the rule cuts at the top alpha (ambiguity 4)
    cut_errors = np.full(scores.M.shape[:2], np.nan)
    top_groups = []
    for s in range(scores.M.shape[0]):
        for a in range(scores.M.shape[1]) if every_alpha else (top,):
            groups = spectral_groups(scores.M[s, a], scores.sizes, K)
            cut_errors[s, a] = clustering_error(y, groups[L])
            if a == top:
                top_groups.append(groups)
    # the grid sigma whose top-alpha cut is the fit's grouping (the nearest one if none is)
    chosen = np.array([np.bincount(model.labels_[idx]).argmax() for idx in leaves])
    agreement = [adjusted_rand_score(chosen, g) for g in top_groups]
    s_fit = int(np.argmax(agreement))
    M = scores.M[s_fit, top]
    ratios = branch_start_ratios(
        y, leaves, M / np.outer(scores.sizes, scores.sizes), per_sequence, Q
    )
    bound = majority_merge_error(y, L)
    redone = cut_errors[~np.isnan(cut_errors)]  # the cells the cut was redone in
    reference = KNNSpectralClustering(K, n_neighbors=10).fit(X).labels_
    return {
        "n": n,
        "draw": draw,
        "Q": Q,
        "kernel path": type(geometry).__name__,
        "leaves": len(leaves),
        "error": clustering_error(y, model.labels_),
        "bound": bound,
        "scikit-learn kNN (k=10)": clustering_error(y, reference),
        "cut over the grid, median": float(np.nanmedian(cut_errors)),
        "cut over the grid, best": float(np.nanmin(cut_errors)),
        "grid cells at the bound": float(np.mean(redone <= bound + 0.005)),
        "cut by alpha, median over sigma": [
            None if np.isnan(e).all() else float(np.nanmedian(e)) for e in cut_errors.T
        ],
        "grid alphas": scores.alphas.tolist(),
        "combination's sigma": float(scores.sigmas[s_fit]),
        "Ncut(bound) / Ncut(chosen)": normalised_cut(M, majority) / normalised_cut(M, chosen),
        "branch-start ratios": ratios,
    }


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--n", type=int, nargs="+", default=[600, 1200, 2400], help="points")
    parser.add_argument("--draws", type=int, nargs="+", default=[0, 1, 2, 3, 4])
    parser.add_argument("--Q", type=int, default=35, help="min_cluster_size")
    parser.add_argument("--out", type=Path, default=None, help="JSON of the rows")
    parser.add_argument(
        "--top-alpha-only", action="store_true", help="redo the cut at the top alpha only"
    )
    args = parser.parse_args(argv)
    if any(n < 2 * K * args.Q for n in args.n):
        parser.error(f"--n: every n must be at least 2 K Q = {2 * K * args.Q}")
    rows = []
    for n in args.n:
        for draw in args.draws:
            row = diagnose(n, draw, args.Q, every_alpha=not args.top_alpha_only)
            rows.append(row)
            r = np.array(row["branch-start ratios"])
            r = r[np.isfinite(r)]
            print(
                f"n={n} draw={draw} ({row['kernel path']}, {row['leaves']} leaves): "
                f"error {row['error']:.3f} bound {row['bound']:.3f} "
                f"sklearn {row['scikit-learn kNN (k=10)']:.3f} | cut over the grid: median "
                f"{row['cut over the grid, median']:.3f}, "
                f"best {row['cut over the grid, best']:.3f}, "
                f"{row['grid cells at the bound']:.0%} of cells at the bound | Ncut(bound) / "
                f"Ncut(chosen) {row['Ncut(bound) / Ncut(chosen)']:.2f} | branch starts tied "
                f"across the junction {int((r > 1).sum())}/{r.size} (median ratio "
                f"{np.median(r) if r.size else float('nan'):.2f})",
                flush=True,
            )
    if args.out is not None:
        atomic_write_bytes(args.out, json.dumps(rows, indent=1).encode())
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
