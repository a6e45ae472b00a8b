"""Dev study: the leaves cut in a locally scaled affinity instead of at a grid sigma.

Local scaling (Zelnik-Manor & Perona, NIPS 2004): ``sigma_i`` = the distance from ``x_i`` to
its k-th nearest neighbour (k = 7), ``W_ij = exp(-d_ij^2 / (sigma_i sigma_j))``, ``W_ii = 0``.
On the leaves of the cached fits of ``experiments.manifold.ensemble_combination`` (same dev
seeds, HSV, interleaved, K = 8), the leaves are kept whole and cut into K by
``spectral_groups`` (the cut ``spectral`` makes at one sigma) in two readings:

* ``local scaling, kernel``: the manifold kernel ``(I - alpha S)^-1`` of
  ``S = D^-1/2 W D^-1/2`` at the top grid alpha; the leaves' block sums of its unit columns;
* ``local scaling, affinity``: the leaves' block sums of ``W`` itself.

Stability: the error with the 5th .. 9th neighbour as ``sigma_i`` (7 +- 2). The criterion is
in ``experiments/manifold/README.md``; ``spectral``'s and the ensembles' rows are read from the
ensemble study's JSON (``--ensemble``) so that the table compares the same leaves.

Usage::

    python -m experiments.manifold.local_scaling --root ROOT \
        --seeds 0 2 6 7 11 12 13 14 15 16 --Q 20 --cache out/ensemble \
        --ensemble experiments/manifold/ensemble_combination.json \
        --out experiments/manifold/local_scaling.json
"""

from __future__ import annotations

import argparse
import json
from pathlib import Path

import numpy as np
from scipy.linalg import eigh

from common.fileio import write_json
from experiments.manifold.combination_acceptance import features
from experiments.manifold.ensemble_combination import error, fitted
from mapping import ManifoldClustering, clustering_error
from mapping.distances import squared_distances
from mapping.manifold.kernel import SpectralBasis, alpha_from_t
from mapping.manifold.spectral_combine import spectral_groups
from scripts.manifold.protocol import K

READINGS = ("local scaling, kernel", "local scaling, affinity")
NEIGHBOUR = 7
NEIGHBOURS = range(NEIGHBOUR - 2, NEIGHBOUR + 3)


def local_affinity(sq_dist: np.ndarray, k: int = NEIGHBOUR) -> np.ndarray:
    """``W_ij = exp(-d_ij^2 / (sigma_i sigma_j))``, sigma_i the distance to the k-th neighbour
    (copies of a point are skipped: the k-th distinct neighbour's distance), ``W_ii = 0``."""
    masked = np.where(sq_dist > 0, sq_dist, np.inf)
    np.fill_diagonal(masked, np.inf)
    k = min(k, sq_dist.shape[0] - 1)
    kth = np.sqrt(np.partition(masked, k - 1, axis=1)[:, k - 1])
    finite = kth[np.isfinite(kth)]
    sigma = np.where(np.isfinite(kth), kth, finite.max() if finite.size else 1.0)
    W = np.exp(-sq_dist / np.outer(sigma, sigma))
    np.fill_diagonal(W, 0.0)
    return W


def leaf_blocks(W: np.ndarray, leaves: np.ndarray, alpha: float | None) -> np.ndarray:
    """C x C block sums of W (alpha None) or of the unit columns of the manifold kernel of
    the normalised W at ``alpha``."""
    member = np.eye(int(leaves.max()) + 1)[leaves]
    if alpha is None:
        return member.T @ W @ member
    deg = W.sum(axis=1)
    inv = np.where(deg > 0, 1.0 / np.sqrt(np.maximum(deg, 1e-300)), 0.0)
    S = inv[:, None] * W * inv[None, :]
    lam, Q = eigh(0.5 * (S + S.T))
    basis = SpectralBasis(Q, np.clip(lam, -1.0, 1.0), Q * Q)
    g = basis.gains(np.array([alpha]))
    inv_nu = 1.0 / basis.column_norms(g)[:, 0]
    return basis.group_gram(g, 0, member, inv_nu)


def local_scaling_groups(
    sq_dist: np.ndarray, leaves: np.ndarray, n_clusters: int, alpha: float | None, k: int
) -> np.ndarray:
    """One group per leaf: the normalised cut of the leaves in the locally scaled affinity."""
    M = leaf_blocks(local_affinity(sq_dist, k), leaves, alpha)
    return spectral_groups(M, np.bincount(leaves).astype(float), n_clusters)


def study(X: np.ndarray, fit: dict, alpha: float) -> dict:
    """Each reading's error at k = 7 and at k = 5 .. 9."""
    D2 = squared_distances(X)
    row = {}
    for reading in READINGS:
        a = alpha if reading.endswith("kernel") else None
        errors = {}
        for k in NEIGHBOURS:
            labels = local_scaling_groups(D2, fit["L"], K, a, k)
            empty = np.bincount(labels, minlength=K).min() == 0
            errors[k] = None if empty else error(fit, labels)
        ok = [e for e in errors.values() if e is not None]
        row[reading] = {
            "error": errors[NEIGHBOUR],
            "neighbours": [errors[k] for k in NEIGHBOURS],
            "spread": max(ok) - min(ok) if ok else None,
        }
    return row


def summary(rows: list[dict], names: tuple[str, ...]) -> dict:
    out = {}
    for name in names:
        e = np.array([r[name]["error"] for r in rows], float)
        out[name] = {"mean": float(np.nanmean(e)), "above 0.15": int((e > 0.15).sum())}
        spreads = [r[name]["spread"] for r in rows if r[name].get("spread") is not None]
        if spreads:  # local scaling: over k = 5 .. 9; the others: over the 5 grid windows
            key = "k 5..9" if name in READINGS else "the 5 grid windows"
            out[name][f"mean spread over {key}"] = float(np.mean(spreads))
    return out


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--root", type=Path, required=True, help="folder of m-data-S datasets")
    parser.add_argument("--seeds", type=int, nargs="+", required=True)
    parser.add_argument("--Q", type=int, default=20, help="min_cluster_size of the fits")
    parser.add_argument("--cache", type=Path, required=True, help="folder of cached fits")
    parser.add_argument("--ensemble", type=Path, help="the ensemble study's JSON (same seeds)")
    parser.add_argument("--out", type=Path, help="JSON file of the per-seed rows and summary")
    args = parser.parse_args(argv)
    args.cache.mkdir(parents=True, exist_ok=True)
    earlier = {}
    if args.ensemble:
        for r in json.loads(args.ensemble.read_text())[f"Q={args.Q}"]["rows"]:
            earlier[r["seed"]] = r
    rows = []
    for seed in args.seeds:
        X, y, _, _ = features(args.root, "interleaved", seed)
        fit = fitted(args.root, args.cache, seed, args.Q)
        assert np.array_equal(fit["y"], y), "the cached fit is not of these frames"
        space = ManifoldClustering(K, args.Q)._search_space(len(y))
        alpha = float(alpha_from_t(space.t_grid()[-1]))
        row = {"seed": seed, "spectral (fit)": {"error": clustering_error(y, fit["labels"])}}
        row.update(study(X, fit, alpha))
        if seed in earlier:
            for name in ("spectral", "coassociation", "coassociation K..K+3", "consensus"):
                row[name] = earlier[seed][name]
            row["oracle"] = {"error": earlier[seed]["oracle"]}
        rows.append(row)
        print(seed, {k: round(v["error"], 3) for k, v in row.items() if k != "seed"}, flush=True)
    names = tuple(k for k in rows[0] if k != "seed")
    result = {"Q": args.Q, "k": NEIGHBOUR, "summary": summary(rows, names), "rows": rows}
    print(json.dumps(result["summary"], indent=1))
    if args.out:
        write_json(args.out, result, indent=1)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
