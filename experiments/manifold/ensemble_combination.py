"""Dev study: combinations of the leaves that read every grid sigma's cut as an ensemble.

For each dev dataset seed (HSV features, interleaved split, K = 8) and leaf size Q, one fit of
``ManifoldClustering`` gives the leaves, the k-NN-adjacent pairs of leaves and the leaves' block
sums ``M[s, a]`` of the kernel (``mapping.manifold.tree.GroupScores``). On these same leaves the
study scores, by train error (Hungarian-matched):

* ``spectral``: the default, the cut at the one sigma of largest total Omega(2) (eq. 9);
* ``coassociation`` and ``consensus``: the ensemble rules of
  ``mapping.manifold.ensemble_combine`` (evidence accumulation; the member of largest mean
  NMI with the rest);
* ``oracle``: the best grouping of the leaves into K given the labels (a ceiling, no method).

Stability over the sigma grid: every rule is rerun on the five windows of ``S - 4`` adjacent
grid sigmas (dropping 0..4 sigmas at the low end and 4..0 at the high end), and the spread
(largest minus smallest error) over the windows is reported; for ``spectral`` also the errors
of the cuts at its chosen sigma and the two grid sigmas each side of it (``neighbours``).
The criterion for choosing among the rules is in ``experiments/manifold/README.md``.

Usage::

    python -m experiments.manifold.ensemble_combination --root ROOT --seeds 0 2 6 7 \
        --Q 35 20 --cache out/ensemble --out experiments/manifold/ensemble_combination.json
"""

from __future__ import annotations

import argparse
import json
import warnings
from pathlib import Path

import numpy as np

from experiments.manifold.split_manifold import k_group_oracle
from mapping import ManifoldClustering, clustering_error
from mapping.manifold.ensemble_combine import coassociation_groups, consensus_groups
from mapping.manifold.geometry import training_geometry
from mapping.manifold.spectral_combine import spectral_groups
from mapping.manifold.tree import GroupScores, adjacent_pairs
from scripts.manifold.protocol import K

#: rule name -> (ensemble_merge's rule, its ``extra``)
VARIANTS = {
    "coassociation": ("coassociation", 0),
    "coassociation K..K+3": ("coassociation", 3),
    "consensus": ("consensus", 0),
}
RULES = ("spectral", *VARIANTS)
WINDOWS = 5  # grid windows of S - (WINDOWS - 1) adjacent sigmas


def fitted(root: Path, cache: Path, seed: int, Q: int) -> dict:
    """The cached leaves, adjacency and block sums of one fit (computed and stored if missing)."""
    from experiments.manifold.combination_acceptance import features

    path = cache / f"e-{seed}-{Q}.npz"
    if not path.exists():
        X, y, _, _ = features(root, "interleaved", seed)
        model = ManifoldClustering(K, Q).fit(X)
        L = model.leaf_labels_
        leaves = [np.flatnonzero(L == c) for c in range(int(L.max()) + 1)]
        geometry = training_geometry(X, model.kernel, model.n_neighbors, model.n_components)
        scores = GroupScores(geometry, leaves, model._search_space(len(y)))
        adjacent = np.array(sorted(adjacent_pairs(geometry.neighbours(10), L))).reshape(-1, 2)
        tmp = path.with_suffix(".tmp.npz")
        np.savez(
            tmp, y=y, L=L, M=scores.M, sizes=scores.sizes, labels=model.labels_, adjacent=adjacent
        )
        tmp.replace(path)
    with np.load(path, allow_pickle=False) as data:
        return {key: data[key] for key in ("y", "L", "M", "sizes", "labels", "adjacent")}


def cuts(fit: dict, n_groups: int) -> list[np.ndarray | None]:
    """The spectral cut into ``n_groups`` at every grid sigma (top alpha); None where the
    sigma is unusable (a k-NN-adjacent pair without affinity, or an empty group)."""
    top, adj, out = fit["M"].shape[1] - 1, fit["adjacent"], []
    for M in fit["M"][:, top]:
        if adj.size and np.any(M[adj[:, 0], adj[:, 1]] <= 0):
            out.append(None)
            continue
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")  # k-means on tied rows: a result here
            labels = spectral_groups(M, fit["sizes"], n_groups)
        out.append(labels if np.bincount(labels, minlength=n_groups).min() > 0 else None)
    return out


def omega_total(fit: dict, s: int, labels: np.ndarray) -> float:
    """Sum over the K groups of group-vs-rest Omega(2) (eq. 9) at grid sigma s, top alpha."""
    M, sizes = fit["M"][s, -1], fit["sizes"]
    member = np.eye(K)[labels]
    size, n = sizes @ member, sizes.sum()
    Mg = member.T @ M @ member
    within, total = np.diag(Mg), Mg.sum(axis=1)
    spread = (1 - (total - within) / (size * (n - size))) - (1 - within / (size * size))
    return float((np.minimum(size, n - size) / n * spread).sum())


def grouping(fit: dict, parts: dict, rule: str, window: range) -> np.ndarray | None:
    """One group per leaf by ``rule`` from the cuts of the sigmas in ``window``."""
    usable = [s for s in window if parts[K][s] is not None]
    if not usable:
        return None
    if rule == "spectral":
        return parts[K][max(usable, key=lambda s: omega_total(fit, s, parts[K][s]))]
    rows = np.array([parts[K][s] for s in usable])
    if rule == "consensus":
        return consensus_groups(rows, fit["sizes"])
    finer = [parts[K + e][s] for e in range(1, VARIANTS[rule][1] + 1) for s in usable]
    rows = np.concatenate([rows, [f for f in finer if f is not None]]) if finer else rows
    return coassociation_groups(rows, K)


def error(fit: dict, labels: np.ndarray | None) -> float | None:
    return None if labels is None else clustering_error(fit["y"], labels[fit["L"]])


def study(fit: dict) -> dict:
    """Every rule's error on all sigmas and on each grid window; the oracle; the neighbours."""
    S = fit["M"].shape[0]
    parts = {K + e: cuts(fit, K + e) for e in range(max(v[1] for v in VARIANTS.values()) + 1)}
    row = {"leaves": len(fit["sizes"]), "oracle": k_group_oracle(fit["y"], fit["L"])}
    for rule in RULES:
        windows = [
            error(fit, grouping(fit, parts, rule, range(j, S - WINDOWS + 1 + j)))
            for j in range(WINDOWS)
        ]
        ok = [e for e in windows if e is not None]
        row[rule] = {
            "error": error(fit, grouping(fit, parts, rule, range(S))),
            "windows": windows,
            "spread": max(ok) - min(ok) if ok else None,
        }
    usable = [s for s in range(S) if parts[K][s] is not None]
    s = max(usable, key=lambda t: omega_total(fit, t, parts[K][t]))
    near = [
        error(fit, parts[K][t])
        for t in range(max(0, s - 2), min(S, s + 3))
        if parts[K][t] is not None
    ]
    row["spectral"]["neighbours"] = {
        "sigma index": s,
        "errors": near,
        "spread": max(near) - min(near),
    }
    return row


def summary(rows: list[dict]) -> dict:
    out = {}
    for rule in (*RULES, "oracle"):
        e = np.array([r[rule] if rule == "oracle" else r[rule]["error"] for r in rows], float)
        out[rule] = {"mean": float(e.mean()), "above 0.15": int((e > 0.15).sum())}
        if rule != "oracle":
            out[rule]["mean spread over windows"] = float(
                np.mean([r[rule]["spread"] for r in rows])
            )
    out["spectral"]["mean spread over neighbouring sigmas"] = float(
        np.mean([r["spectral"]["neighbours"]["spread"] for r in rows])
    )
    return out


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--root", type=Path, required=True, help="folder of m-data-S datasets")
    parser.add_argument("--seeds", type=int, nargs="+", required=True)
    parser.add_argument("--Q", type=int, nargs="+", default=[35], help="min_cluster_size")
    parser.add_argument("--cache", type=Path, required=True, help="folder of cached fits")
    parser.add_argument("--out", type=Path, help="JSON file of the per-seed rows and summary")
    args = parser.parse_args(argv)
    args.cache.mkdir(parents=True, exist_ok=True)
    result = {}
    for Q in args.Q:
        rows = []
        for seed in args.seeds:
            rows.append({"seed": seed, **study(fitted(args.root, args.cache, seed, Q))})
            cells = ", ".join(
                f"{r}={rows[-1][r]['error']:.3f} (spread {rows[-1][r]['spread']:.3f})"
                for r in RULES
            )
            print(f"Q={Q} seed {seed}: oracle={rows[-1]['oracle']:.3f}, {cells}", flush=True)
        result[f"Q={Q}"] = {"summary": summary(rows), "rows": rows}
        print(f"Q={Q}", json.dumps(result[f"Q={Q}"]["summary"]), flush=True)
    if args.out:
        args.out.write_text(json.dumps(result, indent=1) + "\n")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
