"""Recursive minimum-normalised-cut partition of an observation graph (Blanco et al., Section II).

The functional core works on any symmetric non-negative weight matrix (dense or
``scipy.sparse``): ``ncut`` is eq. 1, ``spectral_bisection`` solves eq. 10-11 and splits the
second eigenvector at its mean, ``recursive_ncut_partition`` applies the bisection while the cut
is accepted (eq. 12-13, Section II-B). ``ObservationGraphPartitioner`` is the laser-scan
estimator built on it (Sections III-IV).
"""

from __future__ import annotations

import itertools
from collections.abc import Iterator, Sequence
from dataclasses import dataclass

import numpy as np
import scipy.linalg
import scipy.sparse as sp
import scipy.sparse.linalg
from numpy.typing import ArrayLike
from scipy.sparse.csgraph import connected_components

from mapping.icp import refine_poses
from mapping.overlap import check_scans_and_poses, sensed_space_overlap
from mapping.topology import (
    TopologicalMap,
    build_local_maps,
    build_topology,
    check_run_starts,
    group_frames,
)

__all__ = [
    "ObservationGraphPartitioner",
    "SplitNode",
    "ncut",
    "recursive_ncut_partition",
    "spectral_bisection",
]

_ASSOC = ("mrpt", "paper")
_LAPLACIAN = ("normalized", "unnormalized")
_SOLVERS = ("auto", "dense", "sparse")
# Below this many nodes a dense eigendecomposition beats ARPACK's shift-invert (see the docs'
# benchmark); above it the dense O(n^3) solve dominates the fit.
DENSE_MAX_NODES = 200
# Shift for the shift-invert Lanczos: just below the zero eigenvalue of the Laplacian.
_SHIFT = -1e-3


def _check_weights(W: ArrayLike | sp.sparray, name: str = "W") -> np.ndarray | sp.csr_array:
    """Return ``W`` as float ndarray or csr_array after checking it is a valid graph."""
    if sp.issparse(W):
        W = sp.csr_array(W, dtype=float)
        values = W.data
    else:
        W = np.asarray(W, dtype=float)
        values = W
    if W.ndim != 2 or W.shape[0] != W.shape[1]:
        raise ValueError(f"{name} must be a square matrix, got shape {W.shape}")
    if not np.isfinite(values).all():
        raise ValueError(f"{name} contains NaN or inf")
    if (values < 0).any():
        raise ValueError(f"{name} must be non-negative (weights are overlaps or similarities)")
    asym = abs(W - W.T).max()
    if asym > 1e-9 * max(1.0, abs(values).max(initial=0.0)):
        raise ValueError(f"{name} must be symmetric (max |W - W.T| = {asym:.3g})")
    return W


def _check_solver(solver: str) -> None:
    if solver not in _SOLVERS:
        raise ValueError(f"solver must be one of {_SOLVERS}, got {solver!r}")


def ncut(W: ArrayLike | sp.sparray, mask: ArrayLike, assoc: str = "mrpt") -> float:
    """Normalised cut of the bisection ``A = mask``, ``B = ~mask`` (eq. 1).

    ``Ncut = cut(A, B) / assoc(A, V) + cut(A, B) / assoc(B, V)`` with ``cut`` the summed
    weight between the groups (eq. 2). ``assoc`` selects how the association is counted:

    - ``"mrpt"``: ``assoc(A, V) = cut(A, B) + assoc(A, A)`` (eq. 5) with ``assoc(A, A)`` the
      weight of each unordered pair inside ``A`` counted once, self-weights excluded, the same
      basis as ``cut``. This is MRPT's ``CGraphPartitioner::nCut``.
    - ``"paper"``: eq. 3 as written, ``sum_{u in A, v in V} W_uv``: the degree volume, which
      counts each pair inside ``A`` twice and includes the diagonal.

    Returns 0 when ``cut(A, B) = 0`` (two disconnected groups), else a value in ``(0, 2]``.

    Raises
    ------
    ValueError
        If ``mask`` does not have one entry per node, or one side of the bisection is empty.
    """
    if assoc not in _ASSOC:
        raise ValueError(f"assoc must be one of {_ASSOC}, got {assoc!r}")
    W = _check_weights(W)
    mask = np.asarray(mask, dtype=bool)
    if mask.shape != (W.shape[0],):
        raise ValueError(f"mask must have shape ({W.shape[0]},), got {mask.shape}")
    if mask.all() or not mask.any():
        raise ValueError("mask must put at least one node on each side of the bisection")
    return _ncut(W, mask, assoc)


def _ncut(W: np.ndarray | sp.csr_array, mask: np.ndarray, assoc: str) -> float:
    x = mask.astype(float)
    wx = W @ x  # weight from each node into A
    deg = np.asarray(W.sum(axis=1)).ravel()
    vol_a = float(x @ deg)
    within_a = float(x @ wx)  # ordered pairs in A, diagonal included
    cut = vol_a - within_a
    if cut <= 0:
        return 0.0
    vol_b = float(deg.sum()) - vol_a
    if assoc == "paper":  # eq. 3
        return cut / vol_a + cut / vol_b
    diag = W.diagonal()
    # eq. 5 with intra-group pairs once and no self-weights, as in MRPT
    assoc_aa = 0.5 * (within_a - float(x @ diag))
    assoc_bb = 0.5 * (vol_b - cut - float((1.0 - x) @ diag))
    return cut / (cut + assoc_aa) + cut / (cut + assoc_bb)


def spectral_bisection(
    W: ArrayLike | sp.sparray, laplacian: str = "normalized", solver: str = "auto"
) -> tuple[np.ndarray, np.ndarray]:
    """Bisect a graph with the second eigenvector of its Laplacian, split at its mean.

    ``laplacian="normalized"`` solves the generalised eigenproblem ``(D - W) y = lambda D y``
    (eq. 10) through its symmetric form ``D^-1/2 (D - W) D^-1/2 z = lambda z``, ``y = D^-1/2 z``
    (eq. 11), whose second-smallest eigenvector relaxes the min-Ncut problem (eq. 8).
    ``"unnormalized"`` uses ``(D - W) y = lambda y`` as MRPT does. Nodes with ``y >= mean(y)``
    form ``A`` (the paper's choice over the sign, Section II-A).

    A disconnected graph has a multiple zero eigenvalue, so its "second eigenvector" is any
    combination of component indicators; the bisection then separates the connected component
    of node 0 from the rest (a cut of weight 0, the limit the eigenvector approaches).

    Parameters
    ----------
    W : array-like or sparse matrix of shape (n, n)
        Symmetric non-negative weights, ``n >= 2``.
    laplacian : {"normalized", "unnormalized"}
    solver : {"auto", "dense", "sparse"}
        ``"dense"``: LAPACK on the full matrix; ``"sparse"``: ARPACK shift-invert Lanczos;
        ``"auto"``: dense up to ``DENSE_MAX_NODES`` nodes.

    Returns
    -------
    mask : ndarray of shape (n,), bool
        Membership of ``A``; oriented so that node 0 is in ``A``.
    y : ndarray of shape (n,)
        The eigenvector (the component indicator for a disconnected graph).
    """
    if laplacian not in _LAPLACIAN:
        raise ValueError(f"laplacian must be one of {_LAPLACIAN}, got {laplacian!r}")
    _check_solver(solver)
    W = _check_weights(W)
    if W.shape[0] < 2:
        raise ValueError(f"W must have at least 2 nodes to bisect, got {W.shape[0]}")
    return _bisect(W, laplacian, solver)


def _bisect(W, laplacian: str, solver: str) -> tuple[np.ndarray, np.ndarray]:
    """``spectral_bisection`` without the input checks (the recursion checks ``W`` once)."""
    n_comp, comp = connected_components(sp.csr_array(W), directed=False)
    if n_comp > 1:
        y = (comp == comp[0]).astype(float)
        return y > 0.5, y
    deg = np.asarray(W.sum(axis=1)).ravel()
    y = _second_eigenvector(W, deg, laplacian, solver)
    mask = y >= y.mean()
    if not mask[0]:
        mask, y = ~mask, -y
    return mask, y


def _second_eigenvector(W, deg: np.ndarray, laplacian: str, solver: str) -> np.ndarray:
    n = W.shape[0]
    scale = 1.0 / np.sqrt(deg) if laplacian == "normalized" else np.ones(n)
    use_dense = solver == "dense" or (solver == "auto" and n <= DENSE_MAX_NODES) or n < 4
    if use_dense:
        Wd = W.toarray() if sp.issparse(W) else W
        L = np.diag(deg) - Wd
        L = scale[:, None] * L * scale[None, :]  # eq. 11: D^-1/2 (D - W) D^-1/2
        _, z = scipy.linalg.eigh(L, subset_by_index=[1, 1])
        z = z[:, 0]
    else:
        Ws = sp.csr_array(W)
        L = sp.diags_array(deg) - Ws
        L = (sp.diags_array(scale) @ L @ sp.diags_array(scale)).tocsc()
        # a fixed start vector keeps ARPACK deterministic
        v0 = np.linspace(1.0, 2.0, n)
        _, z = scipy.sparse.linalg.eigsh(L, k=2, sigma=_SHIFT, which="LM", v0=v0)
        z = z[:, 1]
    return scale * z  # back to y of eq. 10 (identity for the unnormalised Laplacian)


@dataclass
class SplitNode:
    """A node of the recursive bisection tree.

    Attributes
    ----------
    indices : ndarray of int
        Nodes of the original graph in this subgraph.
    ncut : float or None
        Ncut (eq. 1) of the best bisection found for this subgraph, whether accepted or not;
        ``None`` when no bisection was possible (a single node, or a constant eigenvector).
    children : tuple of SplitNode
        The two halves if the bisection was accepted (``ncut < threshold``), else empty.
    """

    indices: np.ndarray
    ncut: float | None
    children: tuple[SplitNode, ...] = ()

    @property
    def accepted(self) -> bool:
        """Whether this subgraph was split."""
        return bool(self.children)

    def walk(self) -> Iterator[SplitNode]:
        """Pre-order traversal of the tree."""
        yield self
        for child in self.children:
            yield from child.walk()

    def leaves(self) -> list[SplitNode]:
        """The final groups, in traversal order."""
        return [node for node in self.walk() if not node.children]


def recursive_ncut_partition(
    W: ArrayLike | sp.sparray,
    threshold: float = 1.0,
    *,
    assoc: str = "mrpt",
    laplacian: str = "normalized",
    min_size: int = 1,
    solver: str = "auto",
) -> tuple[np.ndarray, SplitNode]:
    """Recursive spectral bisection while the min-Ncut is below ``threshold`` (Section II-B).

    ``RecursivePart(G)``: bisect ``G`` with ``spectral_bisection``; if ``Ncut < threshold``
    (eq. 12-13 give ``threshold = 1``) partition both halves again, else ``G`` is a group.

    Parameters
    ----------
    W : array-like or sparse matrix of shape (n, n)
        Symmetric non-negative weights; any similarity graph (scan overlap, image similarity).
    threshold : float, default 1.0
        Accept a bisection while ``Ncut < threshold``; in ``[0, 2]``.
    assoc : {"mrpt", "paper"}
        How ``ncut`` counts the association (see ``ncut``).
    laplacian : {"normalized", "unnormalized"}
        Eigenproblem of the bisection (see ``spectral_bisection``).
    min_size : int, default 1
        Reject a bisection that leaves fewer nodes than this on either side.
    solver : {"auto", "dense", "sparse"}
        Eigensolver (see ``spectral_bisection``).

    Returns
    -------
    labels : ndarray of shape (n,), int
        Group of each node, numbered in the order of each group's first node.
    tree : SplitNode
        The bisection tree with each Ncut.
    """
    if not np.isscalar(threshold) or not 0.0 <= threshold <= 2.0:
        raise ValueError(f"threshold must be a number in [0, 2], got {threshold!r}")
    if int(min_size) != min_size or min_size < 1:
        raise ValueError(f"min_size must be a positive integer, got {min_size!r}")
    for name, value, allowed in (("assoc", assoc, _ASSOC), ("laplacian", laplacian, _LAPLACIAN)):
        if value not in allowed:
            raise ValueError(f"{name} must be one of {allowed}, got {value!r}")
    _check_solver(solver)
    W = _check_weights(W)
    n = W.shape[0]
    if n == 0:
        raise ValueError("W has no nodes")
    W = sp.csr_array(W) if n > DENSE_MAX_NODES else (W.toarray() if sp.issparse(W) else W)
    root = SplitNode(np.arange(n), None)
    stack = [root]
    while stack:  # explicit stack: no recursion limit for long trajectories
        node = stack.pop()
        idx = node.indices
        if idx.size < 2:
            continue
        sub = W[idx][:, idx]
        mask, _ = _bisect(sub, laplacian, solver)
        if mask.all():  # constant eigenvector: nothing to split
            continue
        node.ncut = _ncut(sub, mask, assoc)
        if node.ncut < threshold and min(mask.sum(), (~mask).sum()) >= min_size:
            node.children = (SplitNode(idx[mask], None), SplitNode(idx[~mask], None))
            stack.extend(reversed(node.children))
    labels = np.empty(n, dtype=np.intp)
    leaves = sorted(root.leaves(), key=lambda leaf: leaf.indices.min())
    for k, leaf in enumerate(leaves):
        labels[leaf.indices] = k
    return labels, root


class ObservationGraphPartitioner:
    """Group laser scans into local maps by sensed-space overlap and recursive min-Ncut.

    Blanco et al., Sections III-IV: every scan with its pose is a node of the observation graph
    (eq. 14); the weight of an arc is the sensed-space overlap of the two scans (eq. 15-18); the
    graph is split by recursive spectral bisection while the normalised cut is below
    ``threshold`` (eq. 1, 10-13). Each group's scans are merged into a local map and the groups
    are linked into a metric-topological map (Section IV-A, steps 3-4).

    Parameters
    ----------
    threshold : float, default 1.0
        Accept a bisection while its Ncut is below this (eq. 12-13).
    match_distance : float, default 0.1
        Tolerance ``delta`` of eq. 16, in metres.
    assoc : {"mrpt", "paper"}, default "mrpt"
        How the association of eq. 1 is counted (see ``ncut``); ``"mrpt"`` is the basis on
        which the threshold of 1 separates rooms, see ``docs/observation-grouping.md``.
    laplacian : {"normalized", "unnormalized"}, default "normalized"
        Eigenproblem of the bisection: eq. 10 (the paper) or MRPT's ``(D - W) y = lambda y``.
    min_size : int, default 1
        Smallest group a bisection may create.
    scan_matching : bool, default True
        Refine consecutive poses by ICP (``mapping.icp.refine_poses``) before the overlap; on by
        default because raw odometry splits the default sequences (docs/observation-grouping.md).
    icp_max_distance : float, default 0.5
        Correspondence gate of the ICP in metres.
    empty_scans : {"nearest", "noise"}, default "nearest"
        Scans without points overlap nothing, so they stay out of the partition. ``"nearest"``
        gives each the group of the nearest scan with points along the trajectory (the earlier
        one on a tie); ``"noise"`` labels them -1.
    solver : {"auto", "dense", "sparse"}, default "auto"
        Eigensolver of the bisections.

    Attributes
    ----------
    labels_ : ndarray of shape (N,)
        Group of each scan, numbered in order of first appearance.
    affinity_matrix_ : scipy.sparse.csr_array of shape (N, N)
        The sensed-space-overlap weights ``W`` (eq. 18).
    split_tree_ : SplitNode
        The recursive bisection with each Ncut (indices into all scans).
    n_groups_ : int
    poses_ : ndarray of shape (N, 3)
        Poses used for the overlap (ICP-refined when ``scan_matching``).
    local_maps_ : list of ndarray of shape (P_k, 2)
        Each group's points in the frame of its reference scan ``topology_.reference_scans[k]``
        (the scan closest to the group's mean position; see ``mapping.topology.group_frames``).
    topology_ : mapping.topology.TopologicalMap
        Groups as nodes, arcs with relative transformations between local-map frames.
    """

    def __init__(
        self,
        threshold: float = 1.0,
        match_distance: float = 0.1,
        *,
        assoc: str = "mrpt",
        laplacian: str = "normalized",
        min_size: int = 1,
        scan_matching: bool = True,
        icp_max_distance: float = 0.5,
        empty_scans: str = "nearest",
        solver: str = "auto",
    ) -> None:
        self.threshold = threshold
        self.match_distance = match_distance
        self.assoc = assoc
        self.laplacian = laplacian
        self.min_size = min_size
        self.scan_matching = scan_matching
        self.icp_max_distance = icp_max_distance
        self.empty_scans = empty_scans
        self.solver = solver

    def fit(
        self,
        scans: Sequence[ArrayLike],
        poses: ArrayLike,
        *,
        run_starts: ArrayLike | None = None,
    ) -> ObservationGraphPartitioner:
        """Group ``scans`` taken at ``poses`` and build the local maps and topology.

        Parameters
        ----------
        scans : sequence of array-like of shape (M_i, 2)
            Points in each sensor frame; ``M_i`` may be 0.
        poses : array-like of shape (N, 3)
            World poses ``(x, y, yaw)``, e.g. odometry.
        run_starts : array-like of int, optional
            Indices where another run (drive) of the same place begins, when several are
            grouped together in one common frame. The overlap does not care, but consecutive
            indices across a run boundary are not trajectory neighbours: the scan matching does
            not chain across them, arcs ``via`` the trajectory do not join them, and an empty
            scan takes its group from its own run.

        Returns
        -------
        self
        """
        md = self.match_distance
        if not np.isscalar(md) or not np.isfinite(md) or md <= 0:
            raise ValueError(f"match_distance must be a positive distance in metres, got {md!r}")
        if self.empty_scans not in ("nearest", "noise"):
            raise ValueError(f"empty_scans must be 'nearest' or 'noise', got {self.empty_scans!r}")
        scans, poses = check_scans_and_poses(scans, poses)
        starts = check_run_starts(run_starts, len(scans))
        if self.scan_matching:
            poses = refine_poses(
                scans,
                poses,
                max_correspondence_distance=self.icp_max_distance,
                run_starts=np.flatnonzero(starts),
            )
        W = sensed_space_overlap(scans, poses, self.match_distance, sparse=True)
        has_points = np.array([len(s) > 0 for s in scans])
        kept = np.flatnonzero(has_points)
        labels = np.full(len(scans), -1, dtype=np.intp)
        if kept.size:
            sub_labels, tree = self._partition(W[kept][:, kept])
            labels[kept] = sub_labels
            _reindex(tree, kept)
        else:
            tree = SplitNode(np.arange(0), None)
        if self.empty_scans == "nearest":
            labels = _fill_from_nearest(labels, starts)
        self.poses_ = poses
        self.affinity_matrix_ = W
        self.split_tree_ = tree
        self.labels_ = labels
        self.n_groups_ = int(labels.max()) + 1
        reference, frames = group_frames(poses, labels)
        self.local_maps_ = build_local_maps(scans, poses, labels, frames)
        self.topology_: TopologicalMap = build_topology(
            poses, labels, W, reference, frames, np.flatnonzero(starts)
        )
        return self

    def fit_affinity(self, W: ArrayLike | sp.sparray) -> ObservationGraphPartitioner:
        """Partition a precomputed similarity graph (e.g. of images) the same way.

        Sets ``labels_``, ``affinity_matrix_``, ``split_tree_`` and ``n_groups_`` only: without
        poses there are no local maps or topology.
        """
        W = _check_weights(W)
        self.labels_, self.split_tree_ = self._partition(W)
        self.affinity_matrix_ = sp.csr_array(W)
        self.n_groups_ = int(self.labels_.max()) + 1
        return self

    def fit_predict(self, scans: Sequence[ArrayLike], poses: ArrayLike) -> np.ndarray:
        """``fit`` and return ``labels_``."""
        return self.fit(scans, poses).labels_

    def _partition(self, W) -> tuple[np.ndarray, SplitNode]:
        return recursive_ncut_partition(
            W,
            self.threshold,
            assoc=self.assoc,
            laplacian=self.laplacian,
            min_size=self.min_size,
            solver=self.solver,
        )


def _reindex(tree: SplitNode, kept: np.ndarray) -> None:
    """Map the tree's indices from the partitioned subset back to all scans."""
    for node in tree.walk():
        node.indices = kept[node.indices]


def _fill_from_nearest(labels: np.ndarray, starts: np.ndarray | None = None) -> np.ndarray:
    """Give each ``-1`` the label of the nearest labelled index (the earlier one on a tie).

    With ``starts`` (a mask of run starts) the search stays inside each run; a run without any
    labelled index falls back to the search over all runs.
    """
    if starts is not None and starts[1:].any():
        out = labels.copy()
        bounds = np.append(np.flatnonzero(starts), labels.size)
        for lo, hi in itertools.pairwise(bounds):
            if (labels[lo:hi] >= 0).any():
                out[lo:hi] = _fill_from_nearest(labels[lo:hi])
        return _fill_from_nearest(out) if (out < 0).any() else out
    known = np.flatnonzero(labels >= 0)
    if known.size == 0:
        return np.zeros_like(labels)
    pos = np.searchsorted(known, np.arange(labels.size))
    before = known[np.clip(pos - 1, 0, known.size - 1)]
    after = known[np.clip(pos, 0, known.size - 1)]
    gap_before = np.where(pos > 0, np.arange(labels.size) - before, np.iinfo(np.intp).max)
    gap_after = np.where(pos < known.size, after - np.arange(labels.size), np.iinfo(np.intp).max)
    nearest = np.where(gap_before <= gap_after, before, after)
    return labels[nearest]
