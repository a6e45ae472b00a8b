"""Recursive bisection (Section II-C) and the combination of its C leaves into K clusters.

The tree: every node of at least ``2 Q`` points is split by `best_split` (eq. 9); nodes
smaller than that are leaves, so every leaf has at least Q points.

The combination ("the C clusters are finally combined to give the best K clusters that each
have maximal values of Omega(2)"), by default the spectral cut of the leaves' kernel affinity
(``mapping.manifold.spectral_combine``). The pairwise rule `separability_merge`:
repeatedly merge the two adjacent groups that are least separable as two manifolds, where
separability is eq. 9's spread ``E[D^12] - (E[D^11] + E[D^22]) / 2`` maximised over (sigma,
alpha) on the pair's own
points. The alternative "merge" rule is a greedy agglomeration of leaves. A group G of leaves is
scored by eq. 9 with p1 = G and p2 = the rest of the data, maximised over a (sigma, alpha) grid
on the full data; each step merges the pair of groups that raises the sum of these scores most
(or lowers it least). Because ``E[D_M]`` over any two sets of points is a bilinear form of their
indicator vectors, one C x C matrix per (sigma, alpha) holds everything: merging two groups
adds their rows and columns. The winning (sigma, alpha) of each final group are its
``sigma_j, alpha_j``. ``docs/decisions/004-combining-leaves-into-k-clusters.md`` compares this with
cutting the tree.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import scipy.sparse as sp

from mapping.manifold.ensemble_combine import ENSEMBLE_RULES, ensemble_merge
from mapping.manifold.geometry import (
    GraphGeometry,
    as_geometry,
    sigma_grid,
)
from mapping.manifold.kernel import alpha_from_t
from mapping.manifold.spectral_combine import spectral_merge
from mapping.manifold.split import SearchSpace, Split, best_split, best_splits
from mapping.split_tree import SplitNode

# Rules for combining leaves (docs/guides/manifold-clustering.md, ambiguity 4): "spectral" (the
# default: a normalised cut of the leaves' kernel affinity, mapping.manifold.spectral_combine),
# "coassociation" and "consensus" (every sigma's cut as an ensemble, ensemble_combine),
# "separability" (merge the neighbouring pair least separable as two manifolds), "merge" (greedy
# agglomeration maximising the sum of group-vs-rest Omega(2)) or "cut" (the tree cut into K).
COMBINE_RULES = ("spectral", *ENSEMBLE_RULES, "separability", "merge", "cut")
# Neighbours per point that make two groups "adjacent" candidates for the separability merge.
_ADJACENCY_NEIGHBOURS = 10


@dataclass(eq=False)
class ManifoldNode(SplitNode):
    """A node of the manifold bisection tree.

    Parameters
    ----------
    indices : ndarray of int
        Training indices of the node's points.
    children : tuple of ManifoldNode, default ()
        The two halves of a split node; empty for a leaf.
    omega, sigma, alpha : float, default NaN
        The split's Omega(2), sigma and alpha.
    seeds : tuple of int or None, default None
        The split's seeds.

    Attributes
    ----------
    indices : ndarray of int
        Training indices of the node's points, ascending.
    children : tuple of ManifoldNode
        (p1, p2): p1 is the tight manifold seeded by x_l1, p2 the rest; empty for a leaf.
    omega, sigma, alpha : float
        Omega(2) of the node's split (eq. 9) and the (sigma, alpha) that maximised it;
        NaN for a leaf.
    seeds : tuple of int or None
        Training indices of the split's seeds x_l1, x_l2 (eq. 12); None for a leaf.
    """

    omega: float = np.nan
    sigma: float = np.nan
    alpha: float = np.nan
    seeds: tuple[int, int] | None = None


def build_tree(sq_dist, min_size: int, space: SearchSpace, n_jobs: int | None = None):
    """Bisect recursively until every leaf is smaller than ``2 * min_size`` (Section II-C).

    Level by level: the nodes of one depth are independent, and ``n_jobs`` processes search
    them at once (`best_splits`); the tree is the same for any ``n_jobs``.

    Parameters
    ----------
    sq_dist : ndarray of shape (n, n) or geometry
        The squared distances, or a geometry (``mapping.manifold.geometry``).
    min_size : int
        Q; every split leaves at least Q points on each side.
    space : SearchSpace
        The (sigma, alpha) search of each split.
    n_jobs : int, optional
        Processes that search the nodes of one depth.

    Returns
    -------
    ManifoldNode
        The root of the tree.
    """
    geometry = as_geometry(sq_dist)
    root = ManifoldNode(np.arange(geometry.size))
    level = [root]
    while level:
        todo = [node for node in level if node.indices.shape[0] >= 2 * min_size]
        nodes = [geometry.sub(node.indices) for node in todo]
        # copies of one point (a robot standing still) have no sigma to search: a leaf
        extent = [node.has_extent() for node in nodes]
        todo = [node for node, ok in zip(todo, extent, strict=True) if ok]
        nodes = [node for node, ok in zip(nodes, extent, strict=True) if ok]
        for node, split in zip(todo, best_splits(nodes, min_size, space, n_jobs), strict=True):
            _apply(node, split)
        level = [child for node in todo for child in node.children]
    return root


def _split(node: ManifoldNode, geometry, min_size: int, space: SearchSpace) -> None:
    _apply(node, best_split(geometry.sub(node.indices), min_size, space))


def _apply(node: ManifoldNode, split: Split) -> None:
    idx = node.indices
    node.omega, node.sigma, node.alpha = split.omega, split.sigma, split.alpha
    node.seeds = (int(idx[split.seeds[0]]), int(idx[split.seeds[1]]))
    node.children = (ManifoldNode(idx[split.in_first]), ManifoldNode(idx[~split.in_first]))


def ensure_leaves(root: ManifoldNode, sq_dist, n_clusters: int, space: SearchSpace):
    """Split the largest leaves until there are at least ``n_clusters`` of them.

    Only needed when n is close to ``K * Q``: leaves hold between Q and 2 Q - 1 points, so C
    can fall below K. The extra splits relax Q to half the leaf, the most any split can keep.
    The tree is changed in place.

    Parameters
    ----------
    root : ManifoldNode
        The tree.
    sq_dist : ndarray of shape (n, n) or geometry
        The squared distances, or a geometry.
    n_clusters : int
        K.
    space : SearchSpace
        The (sigma, alpha) search of each split.

    Raises
    ------
    ValueError
        If fewer than ``n_clusters`` leaves can be made (too few distinct samples).
    """
    sq_dist = as_geometry(sq_dist)
    leaves = root.leaves()
    while len(leaves) < n_clusters:
        splittable = [leaf for leaf in leaves if leaf.indices.shape[0] >= 2]
        splittable = [leaf for leaf in splittable if sq_dist.sub(leaf.indices).has_extent()]
        if not splittable:  # ManifoldClustering.fit refuses such X first (check_distinct_rows)
            raise ValueError(
                f"n_clusters={n_clusters} needs at least {n_clusters} distinct samples in X; "
                f"it has {len(leaves)} groups of identical samples"
            )
        node = max(splittable, key=lambda leaf: (leaf.indices.shape[0], -leaf.indices[0]))
        _split(node, sq_dist, max(1, node.indices.shape[0] // 2), space)
        leaves = root.leaves()


@dataclass(frozen=True)
class Combination:
    """K groups of leaves with the (sigma, alpha, Omega) that score each group best.

    Parameters
    ----------
    groups : list of list of int
        The leaves of each group.
    sigmas, alphas, omegas : ndarray of shape (K,)
        Each group's best sigma, alpha and Omega(2).
    """

    groups: list[list[int]]
    sigmas: np.ndarray
    alphas: np.ndarray
    omegas: np.ndarray


class GroupScores:
    """Omega(2) of "group vs rest" for every (sigma, alpha) of a grid, from leaf-level sums.

    ``M[s, a]`` is the C x C matrix of ``(sum_{p_b} v) . (sum_{p_c} v)`` for leaves b, c at
    (sigma_s, alpha_a), built from the eigenbasis of the full S at each grid sigma.

    Parameters
    ----------
    geometry : DenseGeometry or GraphGeometry
        All training points.
    leaves : list of ndarray of int
        Training indices of each leaf.
    space : SearchSpace
        The grid of (sigma, alpha).
    """

    def __init__(self, geometry, leaves: list[np.ndarray], space: SearchSpace):
        n = geometry.size
        lo, hi = geometry.sigma_bounds()
        if isinstance(geometry, GraphGeometry):
            # the split search's grid to the last bit, so the root's bases are reused here
            self.sigmas = np.array(sigma_grid(lo, hi, space.n_sigmas)[1])
        else:
            self.sigmas = np.geomspace(lo, hi, space.n_sigmas)
        ts = space.t_grid()
        self.alphas = alpha_from_t(ts)
        member = np.zeros((n, len(leaves)))
        for c, idx in enumerate(leaves):
            member[idx, c] = 1.0
        self.sizes = member.sum(axis=0)
        if isinstance(geometry, GraphGeometry):
            member = sp.csr_matrix(member)  # one leaf per point: O(n), not O(n C), per alpha
        mats = []
        for sigma in self.sigmas:
            basis = geometry.basis(float(sigma))
            g = basis.gains(self.alphas)
            inv_nu = 1.0 / basis.column_norms(g)
            per_alpha = [basis.group_gram(g, a, member, inv_nu[:, a]) for a in range(len(ts))]
            mats.append(per_alpha)
        self.M = np.array(mats)  # (S, A, C, C)
        self.n = n

    def omega(self, within: np.ndarray, total: np.ndarray, size: np.ndarray) -> np.ndarray:
        """Return eq. 9 with p1 = a group (sum of its block ``within``, of its rows ``total``).

        Parameters
        ----------
        within : ndarray
            Sum of the group's own block.
        total : ndarray
            Sum of the group's rows.
        size : ndarray
            Points in the group.

        Returns
        -------
        ndarray
            Omega(2) of group vs rest, broadcast over the inputs.
        """
        rest = self.n - size
        e_within = 1.0 - within / (size * size)
        e_between = 1.0 - (total - within) / (size * rest)
        return np.minimum(size, rest) / self.n * (e_between - e_within)


def combine_leaves(
    sq_dist,
    leaves: list[np.ndarray],
    n_clusters: int,
    space: SearchSpace,
    groups: list[list[int]] | None = None,
    scores: GroupScores | None = None,
) -> Combination:
    """Merge C leaves into K groups greedily, maximising the sum of their Omega(2).

    Parameters
    ----------
    sq_dist : ndarray of shape (n, n) or geometry
        Squared distances of all training points, or their ``mapping.manifold.geometry``.
    leaves : list of ndarray
        Training indices of each leaf (a partition of 0..n-1).
    n_clusters : int
        K <= C.
    space : SearchSpace
        Grid of (sigma, alpha) to score groups on.
    groups : list of list of int, optional
        A grouping of the leaves decided elsewhere (e.g. `cut_tree`); then only the
        (sigma, alpha) of each group are chosen.
    scores : GroupScores, optional
        The leaves' block sums, if already computed (the merge on a graph computes them).

    Returns
    -------
    Combination
        The groups and each group's best (sigma, alpha, Omega).
    """
    if scores is None:
        scores = GroupScores(as_geometry(sq_dist), leaves, space)
    if groups is None:
        groups = _merge(scores, n_clusters)
    # Block sums of each final group: indicator^T M indicator.
    member = np.zeros((len(scores.sizes), len(groups)))
    for k, group in enumerate(groups):
        member[group, k] = 1.0
    Mg = np.einsum("bk,sabc,cl->sakl", member, scores.M, member)
    sizes = scores.sizes @ member
    diag = np.einsum("saii->sai", Mg)
    om = scores.omega(diag, Mg.sum(axis=3), sizes[None, None, :])
    flat = om.reshape(-1, om.shape[2])
    where = np.argmax(flat, axis=0)
    s_idx, a_idx = np.unravel_index(where, om.shape[:2])
    return Combination(
        groups=groups,
        sigmas=scores.sigmas[s_idx],
        alphas=scores.alphas[a_idx],
        omegas=flat[where, np.arange(flat.shape[1])],
    )


def _merge(scores: GroupScores, n_clusters: int) -> list[list[int]]:
    """Merge greedily the pair of groups that most raises the sum of Omega(2)."""
    groups = [[c] for c in range(len(scores.sizes))]
    # Group-level state: block sums per (sigma, alpha) and sizes; merging adds rows/columns.
    Mg = scores.M.copy()
    sizes = scores.sizes.copy()

    def best(within, total, size):
        om = scores.omega(within, total, size)
        return om.reshape(-1, *om.shape[2:]).max(axis=0)

    while len(groups) > n_clusters:
        diag = np.einsum("saii->sai", Mg)
        rows = Mg.sum(axis=3)
        alone = best(diag, rows, sizes[None, None, :])
        a, b = np.triu_indices(len(groups), k=1)
        merged_within = diag[..., a] + diag[..., b] + 2.0 * Mg[..., a, b]
        merged = best(merged_within, rows[..., a] + rows[..., b], (sizes[a] + sizes[b])[None, None])
        gain = merged - alone[a] - alone[b]
        k = int(np.argmax(gain))
        ga, gb = int(a[k]), int(b[k])
        Mg[..., ga, :] += Mg[..., gb, :]
        Mg[..., :, ga] += Mg[..., :, gb]
        Mg = np.delete(np.delete(Mg, gb, axis=2), gb, axis=3)
        sizes[ga] += sizes[gb]
        sizes = np.delete(sizes, gb)
        groups[ga] = sorted(groups[ga] + groups[gb])
        del groups[gb]
    return groups


def cut_tree(root: ManifoldNode, n_clusters: int) -> list[list[ManifoldNode]]:
    """Cut the tree into K subtrees, an alternative combination; each becomes one cluster.

    The tree is expanded from the root, always splitting the frontier node of highest Omega,
    until there are K subtrees.

    Parameters
    ----------
    root : ManifoldNode
        The tree.
    n_clusters : int
        K.

    Returns
    -------
    list of list of ManifoldNode
        The leaves of each subtree.
    """
    frontier = [root]
    while len(frontier) < n_clusters:
        inner = [node for node in frontier if not node.is_leaf]
        node = max(inner, key=lambda nd: nd.omega)
        frontier.remove(node)
        frontier.extend(node.children)
    return [node.leaves() for node in frontier]


def _pair_separability(geometry, a: np.ndarray, b: np.ndarray, space: SearchSpace):
    """Return max over (sigma, alpha) of ``E[D^ab] - (E[D^aa] + E[D^bb]) / 2`` on a and b.

    eq. 9's spread with the labels fixed, symmetric in a and b and without the balance factor
    (which would make every small group look inseparable). The kernel is the pair's own, so
    how far the rest of the data lies does not enter; the union of a and b is its domain.
    """
    idx = np.concatenate([a, b])
    na, nb = a.shape[0], b.shape[0]
    scores = GroupScores(geometry.sub(idx), [np.arange(na), np.arange(na, na + nb)], space)
    M = scores.M
    e_ab = 1.0 - M[..., 0, 1] / (na * nb)
    e_aa = 1.0 - M[..., 0, 0] / (na * na)
    e_bb = 1.0 - M[..., 1, 1] / (nb * nb)
    return float((e_ab - 0.5 * (e_aa + e_bb)).max())


def _leaf_labels(n: int, leaves: list[np.ndarray]) -> np.ndarray:
    """Return each of the n points' leaf (the leaves partition 0..n-1)."""
    labels = np.empty(n, dtype=np.intp)
    for c, idx in enumerate(leaves):
        labels[idx] = c
    return labels


def adjacent_pairs(nearest: np.ndarray, labels: np.ndarray) -> set[tuple[int, int]]:
    """Return the pairs of groups (i < j) joined by a k-nearest-neighbour edge of some point.

    Parameters
    ----------
    nearest : ndarray of int, shape (n, k)
        Each point's neighbours.
    labels : ndarray of int, shape (n,)
        Each point's group.

    Returns
    -------
    set of tuple of (int, int)
        The adjacent pairs.
    """
    a = np.repeat(labels, nearest.shape[1])
    b = labels[nearest.ravel()]
    keep = a != b
    lo, hi = np.minimum(a[keep], b[keep]), np.maximum(a[keep], b[keep])
    return set(zip(lo.tolist(), hi.tolist(), strict=True))


def separability_merge(
    sq_dist, leaves: list[np.ndarray], n_clusters: int, space: SearchSpace
) -> list[list[int]]:
    """Merge C leaves into K groups, always joining the least separable adjacent pair.

    Candidates are pairs of groups joined by a k-nearest-neighbour edge (manifolds meet where
    their points are neighbours); if none is left, every pair is a candidate. Each pair's
    separability is cached and recomputed only for pairs involving the newly merged group.

    Parameters
    ----------
    sq_dist : ndarray of shape (n, n) or geometry
        The squared distances, or a geometry.
    leaves : list of ndarray of int
        Training indices of each leaf.
    n_clusters : int
        K.
    space : SearchSpace
        The (sigma, alpha) search of each pair's separability.

    Returns
    -------
    list of list of int
        The leaves of each group.
    """
    sq_dist = as_geometry(sq_dist)
    groups = [[c] for c in range(len(leaves))]
    members = [np.asarray(leaf) for leaf in leaves]
    labels = _leaf_labels(sq_dist.size, leaves)
    # A group is named by its leaves, so a score stays valid until either group changes.
    cache: dict[tuple[tuple[int, ...], tuple[int, ...]], float] = {}
    nearest = sq_dist.neighbours(_ADJACENCY_NEIGHBOURS)
    while len(groups) > n_clusters:
        pairs = adjacent_pairs(nearest, labels) or {
            (i, j) for i in range(len(groups)) for j in range(i + 1, len(groups))
        }
        best = None
        for i, j in sorted(pairs):
            ids = (tuple(groups[i]), tuple(groups[j]))
            if ids not in cache:
                cache[ids] = _pair_separability(sq_dist, members[i], members[j], space)
            if best is None or cache[ids] < best[0]:
                best = (cache[ids], i, j)
        _, i, j = best
        groups[i] = sorted(groups[i] + groups[j])
        members[i] = np.sort(np.concatenate([members[i], members[j]]))
        del groups[j], members[j]
        for g, idx in enumerate(members):
            labels[idx] = g
    return groups


def shared_kernel_merge(
    geometry, leaves: list[np.ndarray], n_clusters: int, scores: GroupScores
) -> list[list[int]]:
    """Run `separability_merge` with every pair scored in the kernel of all the points.

    The scalable path's form: a pair's spread ``E[D^ab] - (E[D^aa] + E[D^bb]) / 2`` is read
    from the C x C block sums of ``scores`` (one eigensolve per sigma for the whole fit, the
    ones the combination needs anyway), instead of one search with its own eigensolves per
    candidate pair. Merging two groups adds their rows and columns, as in `_merge`.

    Parameters
    ----------
    geometry : DenseGeometry or GraphGeometry
        All training points.
    leaves : list of ndarray of int
        Training indices of each leaf.
    n_clusters : int
        K.
    scores : GroupScores
        The leaves' block sums.

    Returns
    -------
    list of list of int
        The leaves of each group.
    """
    groups = [[c] for c in range(len(leaves))]
    Mg = scores.M.copy()
    sizes = scores.sizes.copy()
    labels = _leaf_labels(geometry.size, leaves)
    nearest = geometry.neighbours(_ADJACENCY_NEIGHBOURS)
    while len(groups) > n_clusters:
        pairs = adjacent_pairs(nearest, labels) or {
            (i, j) for i in range(len(groups)) for j in range(i + 1, len(groups))
        }
        a, b = np.array(sorted(pairs)).T
        diag = np.einsum("saii->sai", Mg)
        e_ab = 1.0 - Mg[..., a, b] / (sizes[a] * sizes[b])
        e_aa = 1.0 - diag[..., a] / (sizes[a] * sizes[a])
        e_bb = 1.0 - diag[..., b] / (sizes[b] * sizes[b])
        spread = (e_ab - 0.5 * (e_aa + e_bb)).reshape(-1, a.shape[0]).max(axis=0)
        k = int(np.argmin(spread))
        i, j = int(a[k]), int(b[k])
        Mg[..., i, :] += Mg[..., j, :]
        Mg[..., :, i] += Mg[..., :, j]
        Mg = np.delete(np.delete(Mg, j, axis=2), j, axis=3)
        sizes[i] += sizes[j]
        sizes = np.delete(sizes, j)
        groups[i] = sorted(groups[i] + groups[j])
        del groups[j]
        labels[labels == j] = i
        labels[labels > j] -= 1
    return groups


def combine_tree(root: ManifoldNode, sq_dist, n_clusters: int, space: SearchSpace, rule: str):
    """Combine the leaves of ``root`` into ``n_clusters`` groups by ``rule``.

    ``rule`` is one of `COMBINE_RULES` (ambiguity 4); each group gets its (sigma, alpha,
    omega).

    Parameters
    ----------
    root : ManifoldNode
        The tree.
    sq_dist : ndarray of shape (n, n) or geometry
        The squared distances, or a geometry.
    n_clusters : int
        K.
    space : SearchSpace
        The grid of (sigma, alpha).
    rule : str
        One of `COMBINE_RULES`.

    Returns
    -------
    Combination
        The groups and each group's best (sigma, alpha, Omega).
    """
    leaves = [leaf.indices for leaf in root.leaves()]
    if n_clusters == 1:
        one = (np.array([root.sigma]), np.array([root.alpha]), np.array([root.omega]))
        return Combination([list(range(len(leaves)))], *one)
    groups = None
    geometry = as_geometry(sq_dist)
    if rule == "spectral" or rule in ENSEMBLE_RULES:
        scores = GroupScores(geometry, leaves, space)
        labels = _leaf_labels(geometry.size, leaves)
        adjacent = np.array(
            sorted(adjacent_pairs(geometry.neighbours(_ADJACENCY_NEIGHBOURS), labels))
        ).reshape(-1, 2)
        if rule == "spectral":
            groups = spectral_merge(scores, n_clusters, adjacent)
        else:
            groups = ensemble_merge(scores, n_clusters, rule, adjacent)
        if groups is None:  # no sigma gave K non-empty groups: the pairwise rule decides
            groups = shared_kernel_merge(geometry, leaves, n_clusters, scores)
        return combine_leaves(geometry, leaves, n_clusters, space, groups=groups, scores=scores)
    if rule == "separability" and isinstance(geometry, GraphGeometry):
        scores = GroupScores(geometry, leaves, space)
        groups = shared_kernel_merge(geometry, leaves, n_clusters, scores)
        return combine_leaves(geometry, leaves, n_clusters, space, groups=groups, scores=scores)
    if rule == "separability":
        groups = separability_merge(sq_dist, leaves, n_clusters, space)
    elif rule == "cut":
        position = {id(leaf): c for c, leaf in enumerate(root.leaves())}
        groups = [[position[id(leaf)] for leaf in part] for part in cut_tree(root, n_clusters)]
    return combine_leaves(sq_dist, leaves, n_clusters, space, groups=groups)
