"""Other groupings of the same leaves, and the ceiling of any grouping, on the dev seeds.

For each dataset seed (HSV features, interleaved split, K = 8) and leaf size Q, one fit of
``ManifoldClustering`` gives the leaves and the leaves' block sums ``M[s, a]`` of the kernel
(``mapping.manifold.tree.GroupScores``, every grid sigma s and alpha a). Every rule below
regroups these same leaves at the top alpha (where the default cuts, ambiguity 4), and the
train error of its grouping is printed beside:

* ``fit``: the fit's own grouping (the default ``spectral`` rule);
* ``K-group oracle``: the best grouping into exactly K groups given the labels
  (``experiments.manifold.split_manifold.k_group_oracle``): the ceiling of every combination;
* per rule, the grouping at the sigma the rule's own objective picks, and in brackets the
  best grid sigma (chosen on the labels: a ceiling for a better choice of sigma):

  - ``spectral``: the normalised cut of ``M`` (``spectral_combine.spectral_groups``), the
    sigma of the largest total group-vs-rest Omega(2) (eq. 9), as the default but without its
    skipping of sigmas at which two kNN-adjacent leaves have no affinity (so it may differ from
    ``fit``);
  - ``spectral+eigengap``: the same cut, the sigma of the largest eigengap
    ``lam_K - lam_{K+1}`` of ``M v = lam diag(M 1) v`` (the affinity that holds K groups
    most clearly);
  - ``mean-affinity``: the cut of the leaves' mean affinity ``M / (|b| |c|)`` (eq. 5's
    ``1 - E[D_M]``), every leaf one unit whatever its size, sigma by Omega(2);
  - ``average linkage``: join the pair of groups of largest mean affinity until K are left,
    sigma by Omega(2).

Fits are cached per (seed, Q) as ``.npz`` under ``--cache`` (read back without pickle).

Usage::

    python -m experiments.manifold.combination_attempts --root ROOT --seeds 0 11 12 --Q 35 20 \
        --cache out/attempts
"""

from __future__ import annotations

import argparse
import warnings
from pathlib import Path

import numpy as np
from scipy.linalg import eigh

from experiments.manifold.combination_acceptance import features
from experiments.manifold.split_manifold import k_group_oracle
from mapping import ManifoldClustering, clustering_error
from mapping.manifold.geometry import training_geometry
from mapping.manifold.spectral_combine import spectral_groups
from mapping.manifold.tree import GroupScores
from scripts.manifold.protocol import K


def fitted(root: Path, cache: Path, seed: int, Q: int) -> dict:
    """The cached leaves and block sums of one fit (computed and stored if missing)."""
    path = cache / f"c-{seed}-{Q}.npz"
    if not path.exists():
        X, y, _, _ = features(root, "interleaved", seed)
        model = ManifoldClustering(K, Q).fit(X)
        L = model.leaf_labels_
        leaves = [np.flatnonzero(L == c) for c in range(int(L.max()) + 1)]
        geometry = training_geometry(X, model.kernel, model.n_neighbors, model.n_components)
        scores = GroupScores(geometry, leaves, model._search_space(len(y)))
        tmp = path.with_suffix(".tmp.npz")
        np.savez(tmp, y=y, L=L, M=scores.M, sizes=scores.sizes, labels=model.labels_)
        tmp.replace(path)
    with np.load(path, allow_pickle=False) as data:
        return {key: data[key] for key in ("y", "L", "M", "sizes", "labels")}


def omega_sum(M: np.ndarray, sizes: np.ndarray, groups: np.ndarray) -> float:
    """Sum over the K groups of group-vs-rest Omega(2) (eq. 9) in the leaf block sums ``M``."""
    member = np.zeros((len(sizes), K))
    member[np.arange(len(sizes)), groups] = 1.0
    size = sizes @ member
    n = sizes.sum()
    if np.any(size == 0) or np.any(size == n):
        return -np.inf
    Mg = member.T @ M @ member
    within, total = np.diag(Mg), Mg.sum(axis=1)
    e_within = 1.0 - within / (size * size)
    e_between = 1.0 - (total - within) / (size * (n - size))
    return float((np.minimum(size, n - size) / n * (e_between - e_within)).sum())


def eigengap(M: np.ndarray) -> float:
    """``lam_K - lam_{K+1}`` of the generalised problem the spectral cut embeds with."""
    W = np.maximum(M, 0.0)
    lam = eigh(W, np.diag(np.maximum(W.sum(axis=1), 1e-300)), eigvals_only=True)[::-1]
    return float(lam[K - 1] - lam[K]) if lam.size > K else 1.0


def average_linkage(M: np.ndarray, sizes: np.ndarray) -> np.ndarray:
    """Join the two groups of largest mean affinity (block sum over the sizes' product) until
    K groups are left; one group label per leaf."""
    groups = [[c] for c in range(len(sizes))]
    G, s = M.copy(), sizes.astype(float).copy()
    while len(groups) > K:
        mean = G / np.outer(s, s)
        np.fill_diagonal(mean, -np.inf)
        a, b = sorted(np.unravel_index(int(np.argmax(mean)), mean.shape))
        G[a] += G[b]
        G[:, a] += G[:, b]
        G = np.delete(np.delete(G, b, axis=0), b, axis=1)
        s[a] += s[b]
        s = np.delete(s, b)
        groups[a] += groups.pop(b)
    labels = np.zeros(len(sizes), dtype=int)
    for k, group in enumerate(groups):
        labels[group] = k
    return labels


#: rule -> (grouping of the leaves from M and sizes, the score whose largest value picks sigma)
RULES = {
    "spectral": (lambda M, sz: spectral_groups(M, sz, K), omega_sum),
    "spectral+eigengap": (
        lambda M, sz: spectral_groups(M, sz, K),
        lambda M, sz, g: eigengap(M),
    ),
    "mean-affinity": (
        lambda M, sz: spectral_groups(M / np.outer(sz, sz), np.ones(len(sz)), K),
        omega_sum,
    ),
    "average linkage": (average_linkage, omega_sum),
}


def attempts(fit: dict) -> dict:
    """rule -> (train error at the rule's own sigma, the best grid sigma's error)."""
    y, L, M, sizes = fit["y"], fit["L"], fit["M"], fit["sizes"]
    top = M.shape[1] - 1
    row = {
        "leaves": len(sizes),
        "fit": clustering_error(y, fit["labels"]),
        "K-group oracle": k_group_oracle(y, L),
    }
    for name, (group, score) in RULES.items():
        errors, scores = [], []
        for s in range(M.shape[0]):
            with warnings.catch_warnings():
                warnings.simplefilter("ignore")  # k-means on tied rows: a result here
                groups = group(M[s, top], sizes)
            errors.append(clustering_error(y, groups[L]))
            scores.append(score(M[s, top], sizes, groups))
        row[name] = (errors[int(np.argmax(scores))], min(errors))
    return row


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--root", type=Path, required=True, help="folder of m-data-S datasets")
    parser.add_argument("--seeds", type=int, nargs="+", required=True)
    parser.add_argument("--Q", type=int, nargs="+", default=[35], help="min_cluster_size")
    parser.add_argument("--cache", type=Path, required=True, help="folder of cached fits")
    args = parser.parse_args(argv)
    args.cache.mkdir(parents=True, exist_ok=True)
    for Q in args.Q:
        rows = [attempts(fitted(args.root, args.cache, s, Q)) for s in args.seeds]
        for seed, row in zip(args.seeds, rows, strict=True):
            cells = [
                f"{k}={v:.3f}" if isinstance(v, float) else f"{k}={v}"
                for k, v in row.items()
                if not isinstance(v, tuple)
            ]
            cells += [
                f"{k}={v[0]:.3f} ({v[1]:.3f})" for k, v in row.items() if isinstance(v, tuple)
            ]
            print(f"Q={Q} seed {seed}: " + ", ".join(cells), flush=True)
        names = [k for k, v in rows[0].items() if not isinstance(v, int)]
        means = {
            k: float(np.mean([r[k][0] if isinstance(r[k], tuple) else r[k] for r in rows]))
            for k in names
        }
        above = {
            k: int(sum((r[k][0] if isinstance(r[k], tuple) else r[k]) > 0.15 for r in rows))
            for k in names
        }
        print(
            f"Q={Q} mean over {len(rows)} seeds: "
            + ", ".join(f"{k}={v:.3f} (>0.15: {above[k]})" for k, v in means.items())
        )
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
