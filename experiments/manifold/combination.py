"""Dev study of the combination step (ambiguity 4): is the leaves' grouping, not the tree,
what fails, and would another search over the same leaves do better?

Every fit's combination inputs are captured once (the C x C leaf block sums ``M`` of the
kernel at each grid sigma and alpha, the leaf sizes, the leaves joined by a 10-NN edge) and
the leaves' true label counts. Rules are then replayed on those inputs, so a rule costs
milliseconds, not a refit. Errors are training clustering errors of the leaves as grouped
(the fit's own grouping is reproduced exactly by ``spectral``). ``K-bound`` is the best any
grouping of those leaves into K non-empty groups can do (an integer programme over leaf ->
group assignments): unlike the majority-merge bound it stays honest where two manifolds share
every leaf they are in, so that fewer than K labels lead a leaf. Dev data only::

    python -m experiments.manifold.combination ROOT

ROOT holds ``m-data-S`` for the dev seeds 0 and 100-111 (``topomap collect --world all
--seed S --out ROOT/m-data-S``); the paper's four synthetic sets (clean and noise 0.002,
``default_rng(0)``) and the branching sequences (``default_rng(0)``) come with them.
"""

from __future__ import annotations

import argparse
import sys
import warnings
from pathlib import Path

import numpy as np
from scipy.optimize import Bounds, LinearConstraint, linear_sum_assignment, milp

import mapping.manifold.tree as tree
from experiments.manifold.dense_vs_graph import image_split
from mapping.manifold import SYNTHETIC_SETS, ManifoldClustering, branching_sequences
from mapping.manifold.spectral_combine import spectral_groups

DEV_SEEDS = [0, *range(100, 112)]
DEV_POOLS = [(0, 100, 101), (102, 103, 104), (105, 106, 107), (108, 109, 110), (111, 0, 103)]


class Captured:
    """One fit's combination inputs and its leaves' label counts."""

    def __init__(self, scores, adjacent, leaves, y, n_clusters):
        self.M = scores.M[:, -1].copy()  # the top alpha, where ``spectral`` cuts
        self.sizes, self.n, self.K = scores.sizes.copy(), scores.n, n_clusters
        self.omega = scores.omega  # eq. 9 of a group against the rest, from block sums
        self._spectral: dict[int, np.ndarray] = {}  # sigma index -> the default's grouping
        self.adjacent = np.asarray(adjacent).reshape(-1, 2)
        labels = np.unique(y)
        self.counts = np.array([[np.sum(y[idx] == k) for k in labels] for idx in leaves], float)

    def usable(self, s: int) -> bool:
        a = self.adjacent
        return not (a.size and np.any(self.M[s][a[:, 0], a[:, 1]] <= 0))

    def error(self, groups: np.ndarray) -> float:
        table = np.zeros((self.K, self.counts.shape[1]))
        np.add.at(table, groups, self.counts)
        r, c = linear_sum_assignment(-table)
        return 1.0 - table[r, c].sum() / self.counts.sum()

    def k_bound(self) -> float:
        C, L = self.counts.shape
        K = self.K
        gain = np.zeros((C, K))
        gain[:, : min(K, L)] = self.counts[:, : min(K, L)]
        one_group = LinearConstraint(np.kron(np.eye(C), np.ones(K)), 1, 1)
        non_empty = LinearConstraint(np.kron(np.ones(C), np.eye(K)), 1, np.inf)
        res = milp(
            -gain.ravel(),
            constraints=[one_group, non_empty],
            integrality=np.ones(C * K),
            bounds=Bounds(0, 1),
        )
        return 1.0 + res.fun / self.counts.sum()

    def spectral(self, s: int) -> np.ndarray:
        """``spectral_groups`` at grid sigma ``s``, computed once for all rules."""
        if s not in self._spectral:
            self._spectral[s] = spectral_groups(self.M[s], self.sizes, self.K)
        return self._spectral[s]

    def omega_sum(self, s: int, groups: np.ndarray) -> float:
        """The paper's score of a grouping: the sum of its groups' group-vs-rest eq. 9, as
        ``spectral_merge`` scores it."""
        member = np.eye(self.K)[groups]
        size = self.sizes @ member
        if np.any(size == 0):
            return -np.inf
        Mg = member.T @ self.M[s] @ member
        return float(self.omega(np.diag(Mg), Mg.sum(axis=1), size).sum())

    def minus_ncut(self, s: int, groups: np.ndarray) -> float:
        member = np.eye(self.K)[groups]
        if np.any(self.sizes @ member == 0):
            return -np.inf
        Mg = member.T @ np.maximum(self.M[s], 0.0) @ member
        volume = Mg.sum(axis=1)
        return -float(np.sum((volume - np.diag(Mg)) / volume))


def _climb(cap: Captured, s: int, groups: np.ndarray, score, adjacent_only: bool, moves: int):
    """Best single-leaf moves while they raise ``score`` (at most ``moves``)."""
    groups = groups.copy()
    near = np.zeros((len(groups), len(groups)), bool)
    if cap.adjacent.size:
        near[cap.adjacent[:, 0], cap.adjacent[:, 1]] = True
        near |= near.T
    current = score(s, groups)
    for _ in range(moves):
        best, move = current, None
        for c, g0 in enumerate(groups):
            if np.sum(groups == g0) == 1:
                continue
            targets = set(groups[near[c]]) if adjacent_only else set(range(cap.K))
            for g in targets - {g0}:
                groups[c] = g
                value = score(s, groups)
                groups[c] = g0
                if value > best + 1e-12:
                    best, move = value, (c, g)
        if move is None:
            break
        groups[move[0]], current = move[1], best
    return groups


def _candidates(cap: Captured, s: int, extra: str) -> list[np.ndarray]:
    from scipy.linalg import eigh
    from sklearn.cluster import AgglomerativeClustering
    from sklearn.cluster._spectral import cluster_qr

    out = [cap.spectral(s)]
    if extra:
        W = np.maximum(cap.M[s], 0.0)
        _, vectors = eigh(W, np.diag(np.maximum(W.sum(axis=1), 1e-300)))
        embedding = vectors[:, ::-1][:, : cap.K]
        if extra == "qr":
            out.append(cluster_qr(embedding))
        else:
            agg = AgglomerativeClustering(cap.K, linkage="average", metric="cosine")
            out.append(agg.fit(embedding).labels_)
    return out


def replay(cap: Captured, rule: str) -> float:
    """The error of ``rule``: at every usable grid sigma a grouping, the sigma (and
    candidate) with the largest Omega(2) sum wins, as in ``spectral_merge``."""
    best, chosen = -np.inf, None
    for s in range(cap.M.shape[0]):
        if not cap.usable(s):
            continue
        extra = rule.removeprefix("spectral+") if rule.startswith("spectral+") else ""
        for groups in _candidates(cap, s, extra):
            if rule == "climb Omega sum":
                groups = _climb(cap, s, groups, cap.omega_sum, False, 100)
            elif rule == "climb NCut":
                groups = _climb(cap, s, groups, cap.minus_ncut, False, 100)
            elif rule == "one adjacent move, Omega sum":
                groups = _climb(cap, s, groups, cap.omega_sum, True, 1)
            value = cap.omega_sum(s, groups)
            if value > best + 1e-12:
                best, chosen = value, groups
    return np.nan if chosen is None else cap.error(chosen)


RULES = [
    "spectral",
    "climb Omega sum",
    "climb NCut",
    "one adjacent move, Omega sum",
    "spectral+qr",
    "spectral+agg",
]


def _fits(root: Path):
    """(name, X, y, K, Q, kernel) of every dev fit."""
    for seed in DEV_SEEDS:
        X, y, _, _ = image_split(root / f"m-data-{seed}")
        for kernel in ("dense", "sparse"):
            yield f"image seed {seed}, {kernel}", X, y, 8, 35, kernel
    for pool in DEV_POOLS:
        parts = [image_split(root / f"m-data-{seed}")[:2] for seed in pool]
        X, y = (np.concatenate(p) for p in zip(*parts, strict=True))
        for kernel in ("dense", "sparse"):
            yield f"image pool {pool}, {kernel}", X, y, 8, 35, kernel
    for noise in (0.0, 0.002):
        for name, make in SYNTHETIC_SETS.items():
            X, y = make(noise=noise, rng=np.random.default_rng(0))
            yield f"{name}, noise {noise}", X, y, 3, 20, "dense"
    for n in (304, 600, 1200, 2400):
        X, y = branching_sequences(n // 8, 2000, np.random.default_rng(0))
        yield f"branching n = {n}", X, y, 8, min(35, n // 16), "dense" if n <= 600 else "sparse"


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("root", type=Path)
    args = parser.parse_args()
    captured: dict = {}
    spectral_merge = tree.spectral_merge

    def capture(scores, n_clusters, adjacent=None):
        captured["scores"], captured["adjacent"] = scores, adjacent
        captured["leaves"] = [np.asarray(leaf) for leaf in sys._getframe(1).f_locals["leaves"]]
        return spectral_merge(scores, n_clusters, adjacent)

    tree.spectral_merge = capture
    print("| fit | K-bound | " + " | ".join(RULES) + " |")
    print("|---" * (len(RULES) + 2) + "|")
    rows = []
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        for name, X, y, K, Q, kernel in _fits(args.root):
            captured.clear()
            ManifoldClustering(K, Q, kernel=kernel).fit(X)
            cap = Captured(captured["scores"], captured["adjacent"], captured["leaves"], y, K)
            rows.append([cap.k_bound()] + [replay(cap, rule) for rule in RULES])
            print(f"| {name} | " + " | ".join(f"{e:.3f}" for e in rows[-1]) + " |", flush=True)
    print("| mean | " + " | ".join(f"{e:.3f}" for e in np.nanmean(rows, axis=0)) + " |")


if __name__ == "__main__":
    main()
