"""Combinations of the C leaves that do not rest on one sigma.

The spectral cuts of every grid sigma are read as an ensemble of partitions.

The default combination (``mapping.manifold.spectral_combine``, the reading of the paper's
"the C clusters are finally combined to give the best K clusters that each have maximal
values of Omega(2)" used to reproduce it) cuts the leaves' kernel affinity at every grid sigma
and keeps the one cut of the largest total Omega(2) (eq. 9). Between adjacent sigmas that cut
can jump (a manifold halved at one sigma, whole at the next), and the rule inherits the jump.
The rules here keep every usable sigma's cut, the partitions ``P_1 .. P_S`` of the leaves, and
combine them without labels:

``coassociation``
    Evidence accumulation (Fred & Jain, IEEE TPAMI 27(6), 2005): the co-association
    ``A[b, c]`` = the fraction of the partitions (the cuts into K, K + 1, .. K + 3 groups at
    every usable sigma) that put leaves b and c in one group; the K
    clusters are the average-linkage tree of the distance ``1 - A`` cut into K
    (``scipy.cluster.hierarchy``; the leaves are its units).
``consensus``
    The ensemble member that shares the most information with the rest (Strehl & Ghosh, JMLR
    3, 2002: the consensus partition maximises the average normalised mutual information,
    ANMI, with the ensemble; here searched among the members, on the points, so a leaf weighs
    its size). Scale choice by agreement across scales, in the spirit of stability-based
    model selection (Ben-Hur, Elisseeff & Guyon, PSB 2002).

A sigma is usable as in the default rule: at the top alpha of the grid (the long-range
diffusion that joins a manifold's leaves along its length), no pair of k-NN-adjacent leaves
without affinity, and K non-empty groups.
"""

from __future__ import annotations

import numpy as np

from mapping.manifold.spectral_combine import spectral_groups

#: rules of this module (``ManifoldClustering``'s ``combine``)
ENSEMBLE_RULES = ("coassociation", "consensus")
#: "coassociation" also accumulates the cuts into K + 1 .. K + FINER groups (chosen on the dev
#: seeds over none: ``experiments/manifold/README.md``)
FINER = 3


def sigma_partitions(
    scores, n_clusters: int, adjacent: np.ndarray | None = None, sigmas: slice | None = None
) -> np.ndarray:
    """Return the spectral cut of the leaves at every usable grid sigma (top alpha).

    Parameters
    ----------
    scores : mapping.manifold.tree.GroupScores
        The leaves' block sums ``M[s, a]`` at every grid (sigma, alpha).
    n_clusters : int
        K.
    adjacent : ndarray of shape (P, 2), optional
        Pairs of leaves joined by a k-nearest-neighbour edge; a sigma at which the kernel
        gives such a pair no affinity is skipped.
    sigmas : slice, optional
        A window of the grid (all sigmas by default); the stability study shifts it.

    Returns
    -------
    ndarray of shape (P, C)
        One group label per leaf for each of the P usable sigmas (P may be 0).
    """
    n_leaves = scores.sizes.shape[0]
    top = scores.M.shape[1] - 1
    rows = []
    n_clusters = min(n_clusters, n_leaves)
    for s in range(scores.M.shape[0])[sigmas or slice(None)]:
        M = scores.M[s, top]
        if adjacent is not None and adjacent.size:
            if np.any(M[adjacent[:, 0], adjacent[:, 1]] <= 0):
                continue
        labels = spectral_groups(M, scores.sizes, n_clusters)
        if np.bincount(labels, minlength=n_clusters).min() == 0:
            continue
        rows.append(labels)
    return np.array(rows, dtype=np.intp).reshape(len(rows), n_leaves)


def coassociation_groups(partitions: np.ndarray, n_clusters: int) -> np.ndarray:
    """Group the leaves by the average-linkage cut of the co-association (Fred & Jain 2005).

    ``A[b, c] = mean_p [P_p(b) = P_p(c)]``; the tree of ``1 - A`` (UPGMA) is cut into exactly
    ``n_clusters`` groups (``scipy.cluster.hierarchy.cut_tree``).

    Parameters
    ----------
    partitions : ndarray of int, shape (P, C)
        One group label per leaf for each partition.
    n_clusters : int
        K.

    Returns
    -------
    ndarray of int, shape (C,)
        One group per leaf.
    """
    from scipy.cluster.hierarchy import cut_tree, linkage
    from scipy.spatial.distance import squareform

    same = partitions[:, :, None] == partitions[:, None, :]
    distance = 1.0 - same.mean(axis=0)
    np.fill_diagonal(distance, 0.0)
    tree = linkage(squareform(distance, checks=False), method="average")
    return cut_tree(tree, n_clusters=n_clusters).ravel()


def consensus_groups(partitions: np.ndarray, sizes: np.ndarray) -> np.ndarray:
    """Return the partition of largest mean NMI with the others, each leaf counted by its size.

    Strehl & Ghosh 2002, the ANMI criterion restricted to the ensemble's members.

    Parameters
    ----------
    partitions : ndarray of int, shape (P, C)
        One group label per leaf for each partition.
    sizes : ndarray of int, shape (C,)
        Points per leaf.

    Returns
    -------
    ndarray of int, shape (C,)
        The chosen partition.
    """
    from sklearn.metrics import normalized_mutual_info_score

    if len(partitions) == 1:
        return partitions[0]
    points = np.repeat(np.arange(partitions.shape[1]), np.asarray(sizes, dtype=np.intp))
    expanded = partitions[:, points]
    nmi = np.eye(len(partitions))
    for p in range(len(partitions)):
        for q in range(p + 1, len(partitions)):
            nmi[p, q] = nmi[q, p] = normalized_mutual_info_score(expanded[p], expanded[q])
    return partitions[int(np.argmax(nmi.sum(axis=1)))]


def ensemble_merge(
    scores,
    n_clusters: int,
    rule: str,
    adjacent: np.ndarray | None = None,
    sigmas: slice | None = None,
    extra: int = FINER,
) -> list[list[int]] | None:
    """Group the leaves into K by ``rule`` (one of `ENSEMBLE_RULES`) from the usable sigmas' cuts.

    None if no sigma is usable (the caller falls back to a pairwise rule).

    Parameters
    ----------
    scores : mapping.manifold.tree.GroupScores
        The leaves' block sums at every grid (sigma, alpha).
    n_clusters : int
        K.
    rule : {"coassociation", "consensus"}
        The combination.
    adjacent : ndarray of shape (P, 2), optional
        Pairs of leaves joined by a k-nearest-neighbour edge (see `sigma_partitions`).
    sigmas : slice, optional
        A window of the grid; all sigmas by default.
    extra : int, default FINER
        For "coassociation", also the cuts into K + 1 .. K + extra groups at every usable
        sigma (Fred & Jain's ensembles of finer partitions, cut into K by the linkage).

    Returns
    -------
    list of list of int or None
        The leaves of each group; one group per leaf when there are at most K leaves.
    """
    if rule not in ENSEMBLE_RULES:
        raise ValueError(f"rule must be one of {ENSEMBLE_RULES}, got {rule!r}")
    n_leaves = scores.sizes.shape[0]
    if n_leaves <= n_clusters:
        return [[c] for c in range(n_leaves)]
    partitions = sigma_partitions(scores, n_clusters, adjacent, sigmas)
    if len(partitions) == 0:
        return None
    if rule == "coassociation":
        finer = [
            sigma_partitions(scores, n_clusters + e, adjacent, sigmas) for e in range(1, extra + 1)
        ]
        labels = coassociation_groups(np.concatenate([partitions, *finer]), n_clusters)
    else:
        labels = consensus_groups(partitions, scores.sizes)
    return [np.flatnonzero(labels == k).tolist() for k in range(n_clusters)]
