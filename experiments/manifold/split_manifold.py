"""Why the combination of the leaves spends two clusters on one manifold on some image seeds.

For each dataset seed (HSV features, the protocol's interleaved split, K = 8) and each leaf
size Q this study fits ``ManifoldClustering`` and prints:

* the leaves: size, the manifolds they hold, and the cluster the fit gave them; the manifolds'
  sizes (a trunk is driven by all three sequences of its world, so it holds about three times
  a branch's frames);
* the tree against the combination: the fit's error, the majority-merge bound of its leaves
  (every leaf joins its majority manifold, so it may use fewer than K groups) and the
  *K-group oracle*: the best grouping of the leaves into exactly K non-empty groups given the
  labels (`k_group_oracle`), the ceiling of every combination of these leaves;
* the cut's objective: at the sigma the combination chose (top alpha), the normalised cut of
  the leaves' majority grouping over that of the chosen grouping (above 1: the objective
  itself prefers the wrong grouping), and the first K + 2 generalised eigenvalues of
  ``M v = lam diag(M 1) v`` (the eigengap after the K-th says whether the affinity holds K
  groups at all);
* the leaves' F^j(k): for the chosen grouping, each group's eq. 13 signal at its own sigma and
  alpha on the training points; the share of a manifold's points whose largest F^j is a group
  that holds none of its leaves' majority says where ``predict`` goes astray;
* the train error of other groupings of the same leaves: the paper's ``separability`` rule,
  the spectral cut of the leaves' *mean* affinity (every leaf one unit, not its size), and
  the kNN-graph leaf merge of ``experiments.manifold.diagnosis``.

Usage::

    python -m experiments.manifold.split_manifold --root ROOT --seeds 0 2 6 7 --Q 35 20
"""

from __future__ import annotations

import argparse
import json
from pathlib import Path

import numpy as np
from scipy.linalg import eigh

from experiments.manifold.combination_acceptance import features
from experiments.manifold.diagnosis import knn_leaf_merge
from mapping import ManifoldClustering, clustering_error
from mapping.manifold.geometry import training_geometry
from mapping.manifold.spectral_combine import spectral_groups
from mapping.manifold.tree import GroupScores
from mapping.metrics import majority_merge_error
from scripts.manifold.protocol import K


def normalised_cut(affinity: np.ndarray, groups: np.ndarray) -> float:
    """sum_k cut(A_k, rest) / vol(A_k) of a leaf grouping in a C x C leaf affinity."""
    member = np.zeros((len(groups), int(groups.max()) + 1))
    member[np.arange(len(groups)), groups] = 1.0
    Mg = member.T @ np.maximum(affinity, 0.0) @ member
    volume = Mg.sum(axis=1)
    keep = volume > 0
    return float(((volume - np.diag(Mg))[keep] / volume[keep]).sum())


def k_group_oracle(y: np.ndarray, leaves: np.ndarray, n_clusters: int = K) -> float:
    """The smallest error of a grouping of the leaves into exactly ``n_clusters`` non-empty
    groups, given the labels ``y`` (0 .. n_clusters - 1).

    Each group is matched to one label; a leaf in the group of label v scores its points of
    label v. Every leaf takes its majority label except that each label must own at least one
    leaf: which leaves give up their majority for which label is an assignment problem (cost:
    the points a leaf loses by the change), solved exactly by
    ``scipy.optimize.linear_sum_assignment``.
    """
    from scipy.optimize import linear_sum_assignment

    counts = np.zeros((int(leaves.max()) + 1, n_clusters))
    np.add.at(counts, (leaves, y), 1.0)
    rows, labels = linear_sum_assignment(counts.max(axis=1, keepdims=True) - counts)
    grouping = counts.argmax(axis=1)
    grouping[rows] = labels
    return clustering_error(y, grouping[leaves])


def diagnose(X: np.ndarray, y: np.ndarray, Q: int) -> dict:
    """The quantities of the module docstring for one fit."""
    model = ManifoldClustering(K, Q).fit(X)
    L = model.leaf_labels_
    leaves = [np.flatnonzero(L == c) for c in range(int(L.max()) + 1)]
    majority = np.array([np.bincount(y[idx], minlength=K).argmax() for idx in leaves])
    chosen = np.array([np.bincount(model.labels_[idx], minlength=K).argmax() for idx in leaves])
    geometry = training_geometry(X, model.kernel, model.n_neighbors, model.n_components)
    scores = GroupScores(geometry, leaves, model._search_space(len(y)))
    top = scores.M.shape[1] - 1
    # the grid sigma whose top-alpha cut reproduces the fit's grouping
    s_fit = next(
        (
            s
            for s in range(scores.M.shape[0])
            if clustering_error(chosen, spectral_groups(scores.M[s, top], scores.sizes, K)) == 0
        ),
        None,
    )
    row = {
        "leaves": [
            {
                "size": len(idx),
                "manifolds": {
                    int(v): int(c)
                    for v, c in zip(*np.unique(y[idx], return_counts=True), strict=True)
                },
                "cluster": int(chosen[c]),
            }
            for c, idx in enumerate(leaves)
        ],
        "manifold sizes": np.bincount(y, minlength=K).tolist(),
        "error": clustering_error(y, model.labels_),
        "bound": majority_merge_error(y, L),
        "K-group oracle": k_group_oracle(y, L),
    }
    if s_fit is not None:
        M = scores.M[s_fit, top]
        W = np.maximum(M, 0.0)
        lam = eigh(W, np.diag(W.sum(axis=1)), eigvals_only=True)[::-1]
        row["Ncut(majority) / Ncut(chosen)"] = normalised_cut(M, majority) / normalised_cut(
            M, chosen
        )
        row["eigenvalues"] = np.round(lam[: K + 2], 4).tolist()
        mean = M / np.outer(scores.sizes, scores.sizes)
        row["mean-affinity cut error"] = clustering_error(
            y, spectral_groups(mean, np.ones(len(leaves)), K)[L]
        )
    F = model.predict_proba(X)  # (n, K): the normalised eq. 13 F^j of every cluster
    owner = F.argmax(axis=1)
    astray = {}
    for v in range(K):
        homes = set(chosen[majority == v].tolist())
        mine = y == v
        astray[v] = round(float(np.mean([o not in homes for o in owner[mine]])), 3)
    row["share of a manifold whose largest F^j is not its own cluster"] = astray
    row["separability error"] = clustering_error(
        y, ManifoldClustering(K, Q, combine="separability").fit(X).labels_
    )
    row["kNN leaf merge error"] = clustering_error(y, knn_leaf_merge(X, L, K))
    return row


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--root", type=Path, required=True, help="folder of m-data-S datasets")
    parser.add_argument("--seeds", type=int, nargs="+", default=[0, 2, 6, 7])
    parser.add_argument("--Q", type=int, nargs="+", default=[35], help="min_cluster_size")
    args = parser.parse_args(argv)
    for seed in args.seeds:
        X, y, _, _ = features(args.root, "interleaved", seed)
        for Q in args.Q:
            print(json.dumps({"seed": seed, "Q": Q, **diagnose(X, y, Q)}), flush=True)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
