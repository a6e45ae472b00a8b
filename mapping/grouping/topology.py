"""The metric-topological map of grouped observations.

Blanco et al., Section III and Section IV-A step 4: the groups found by the observation-graph
partition become the nodes of a graph; each node stores a local metric map and each arc the
"approximate relative transformation between the local maps", computed "by averaging the
differential poses between scans of different groups".

Poses are ``(x, y, yaw)`` rows; their algebra (``se2_compose``, ``se2_relative``, ...) is
`common.geometry`'s.
"""

from __future__ import annotations

import itertools
from collections.abc import Sequence
from dataclasses import dataclass, field

import numpy as np
from numpy.typing import ArrayLike

from common.geometry import (
    se2_compose,
    se2_inverse,
    se2_relative,
    transform_points,
    wrap_angle,
)
from mapping.run_starts import run_starts_from_groups

__all__ = [
    "TopologicalMap",
    "TopologyArc",
    "build_local_maps",
    "build_topology",
    "check_poses",
    "fill_from_nearest",
    "group_frames",
]


def _check_labels(labels: ArrayLike, n: int | None = None) -> np.ndarray:
    """Return ``labels`` as a 1-D integer array of group labels ``>= -1`` (-1: no group).

    One per scan when ``n`` is given; a ValueError names ``labels`` otherwise.
    """
    labels = np.asarray(labels)
    if labels.size == 0 and labels.ndim == 1:
        labels = labels.astype(np.intp)  # [] is float64 to numpy
    if labels.ndim != 1 or labels.dtype.kind not in "iu":
        raise ValueError(
            "labels must be a 1-D array of integer group labels (-1 for none), got "
            f"{labels.dtype} of shape {labels.shape}"
        )
    if n is not None and labels.shape[0] != n:
        raise ValueError(f"labels must have one entry per scan ({n}), got {labels.shape[0]}")
    if labels.size and labels.min() < -1:
        raise ValueError(f"labels must be -1 (no group) or a group >= 0, got {labels.min()}")
    return labels


def check_poses(poses: ArrayLike) -> np.ndarray:
    """Return ``poses`` as a finite ``(N, 3)`` float array, or raise a ValueError naming it.

    Parameters
    ----------
    poses : array-like of shape (N, 3)
        ``(x, y, yaw)`` poses.

    Returns
    -------
    ndarray of shape (N, 3)
        The poses as floats.
    """
    poses = np.asarray(poses, dtype=float)
    if poses.ndim != 2 or poses.shape[1] != 3:
        raise ValueError(f"poses must have shape (N, 3) of (x, y, yaw), got {poses.shape}")
    if not np.isfinite(poses).all():
        bad = np.flatnonzero(~np.isfinite(poses).all(axis=1))
        raise ValueError(f"poses contains NaN or inf (rows {bad[:5].tolist()})")
    return poses


# --------------------------------------------------------------------------- local maps


def group_frames(poses: np.ndarray, labels: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Choose one reference scan per group: the one closest to the group's mean position.

    The central scan (rather than the first) keeps the lever arm from the frame origin to the
    farthest point of the local map short, so a heading error of the frame moves the map least.

    Parameters
    ----------
    poses : ndarray of shape (N, 3)
        ``(x, y, yaw)`` of each scan.
    labels : ndarray of int, shape (N,)
        Group of each scan, ``0..K-1`` without gaps, -1 for none.

    Returns
    -------
    reference : ndarray of shape (K,), int
        Index of each group's reference scan (groups ``0..K-1``; label ``-1`` is ignored).
    frames : ndarray of shape (K, 3)
        World pose of each reference scan, i.e. of each local map's frame.

    Raises
    ------
    ValueError
        Naming ``labels`` (not one integer per pose, below -1, or a group of ``0..K-1``
        without a scan) or ``poses`` (not a finite ``(N, 3)`` array).
    """
    poses = check_poses(poses)
    labels = _check_labels(labels, poses.shape[0])
    n_groups = int(labels.max()) + 1 if labels.size and labels.max() >= 0 else 0
    present = np.unique(labels[labels >= 0])
    if present.size != n_groups:  # a group without a scan has no reference scan
        gaps = np.setdiff1d(np.arange(n_groups), present)
        raise ValueError(
            f"labels must number the groups 0..K-1 without gaps; no scan has label(s) "
            f"{gaps[:5].tolist()}"
        )
    reference = np.empty(n_groups, dtype=np.intp)
    for k in range(n_groups):
        members = np.flatnonzero(labels == k)
        centre = poses[members, :2].mean(axis=0)
        reference[k] = members[np.argmin(np.sum((poses[members, :2] - centre) ** 2, axis=1))]
    return reference, poses[reference].copy()


def build_local_maps(
    scans: Sequence[np.ndarray], poses: np.ndarray, labels: np.ndarray, frames: np.ndarray
) -> list[np.ndarray]:
    """Merge each group's scans into one point map expressed in the group's frame.

    Section IV-A step 3: one local map per group. Scan ``i`` of group ``k`` is placed with the
    differential pose ``se2_relative(frames[k], poses[i])``.

    Parameters
    ----------
    scans : sequence of ndarray of shape (M_i, 2)
        Sensor-frame points of each scan.
    poses : ndarray of shape (N, 3)
        ``(x, y, yaw)`` of each scan.
    labels : ndarray of int, shape (N,)
        Group of each scan, -1 for none.
    frames : ndarray of shape (K, 3)
        World pose of each group's frame (``group_frames``).

    Returns
    -------
    list of ndarray of shape (P_k, 2)
        Each group's points in its frame.
    """
    poses = check_poses(poses)
    labels = _check_labels(labels, poses.shape[0])
    if len(scans) != labels.shape[0]:
        raise ValueError(
            f"scans must have one scan per label ({labels.shape[0]}), got {len(scans)}"
        )
    maps = []
    for k, frame in enumerate(frames):
        members = np.flatnonzero(labels == k)
        local = se2_relative(frame, poses[members])
        parts = [transform_points(local[m], scans[i]) for m, i in enumerate(members)]
        maps.append(np.concatenate(parts, axis=0) if parts else np.empty((0, 2)))
    return maps


# --------------------------------------------------------------------------- topology


@dataclass(frozen=True)
class TopologyArc:
    """An arc of the topological map between local maps ``source`` and ``target``.

    Parameters
    ----------
    source, target : int
        Group labels, ``source < target``.
    transform : ndarray of shape (3,)
        Pose of the ``target`` frame in the ``source`` frame.
    n_pairs : int
        Number of scan pairs averaged.
    via : frozenset of str
        How the groups are joined: ``"trajectory"``, ``"overlap"`` or both.
    spread : ndarray of shape (2,)
        Spread of the per-pair translations (m) and headings (rad).

    Attributes
    ----------
    source, target : int
        Group labels, ``source < target``.
    transform : ndarray of shape (3,)
        Pose of the ``target`` local-map frame in the ``source`` frame (the mean of the
        per-pair estimates, circular mean for the heading).
    n_pairs : int
        Number of scan pairs averaged.
    via : frozenset of str
        ``"trajectory"`` if consecutive scans cross between the groups, ``"overlap"`` if some
        scan pair of the two groups has positive sensed-space overlap.
    spread : ndarray of shape (2,)
        Standard deviation of the per-pair translations (m, root of summed variances) and the
        circular standard deviation of their headings (rad); near 0 when all poses agree.
    """

    source: int
    target: int
    transform: np.ndarray
    n_pairs: int
    via: frozenset[str]
    spread: np.ndarray


@dataclass
class TopologicalMap:
    """Groups as nodes (each with a local-map frame), arcs with relative transformations.

    Parameters
    ----------
    reference_scans : ndarray of int, shape (n_nodes,)
        The scan that anchors each local map.
    frames : ndarray of shape (n_nodes, 3)
        Each local map's frame as a pose ``(x, y, yaw)`` in the odometry frame.
    arcs : list of TopologyArc, default []
        The arcs between local maps that share observations.

    Attributes
    ----------
    reference_scans, frames, arcs
        The parameters, as given.
    n_nodes : int
        Number of local maps.

    Examples
    --------
    >>> from mapping.grouping import ObservationGraphPartitioner
    >>> from mapping.grouping import office_path, office_world, raycast
    >>> world = office_world()
    >>> poses = office_path(world, step=1.17)
    >>> model = ObservationGraphPartitioner(scan_matching=False)
    >>> topology = model.fit(raycast(world.segments, poses), poses).topology_
    >>> topology.n_nodes, topology.frames.shape
    (8, (8, 3))
    >>> a, b = topology.edges()[0]
    >>> topology.transform(a, b).shape
    (3,)

    See Also
    --------
    mapping.grouping.ObservationGraphPartitioner : Builds this map as ``topology_``.
    mapping.grouping.align_groups : The local maps aligned by ICP.
    """

    reference_scans: np.ndarray
    frames: np.ndarray
    arcs: list[TopologyArc] = field(default_factory=list)

    @property
    def n_nodes(self) -> int:
        """Number of nodes (local maps)."""
        return int(self.frames.shape[0])

    def edges(self) -> list[tuple[int, int]]:
        """Return the arcs as ``(source, target)`` pairs.

        Returns
        -------
        list of tuple of (int, int)
            One pair per arc, ``source < target``.
        """
        return [(arc.source, arc.target) for arc in self.arcs]

    def transform(self, a: int, b: int) -> np.ndarray:
        """Return the pose of local map ``b``'s frame in local map ``a``'s frame.

        The pose is that of the arc ``a``-``b``, inverted when the arc runs from ``b`` to ``a``.

        Parameters
        ----------
        a, b : int
            The two local maps.

        Returns
        -------
        ndarray of shape (3,)
            ``(x, y, yaw)`` of ``b``'s frame in ``a``'s frame.

        Raises
        ------
        KeyError
            If there is no arc between ``a`` and ``b``.
        """
        for arc in self.arcs:
            if (arc.source, arc.target) == (a, b):
                return arc.transform.copy()
            if (arc.source, arc.target) == (b, a):
                return se2_inverse(arc.transform)
        raise KeyError(f"no arc between local maps {a} and {b}")


def _connecting_pairs(
    labels: np.ndarray, affinity, starts: np.ndarray
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Return scan pairs ``(i, j)``, ``i < j``, of different groups joined by path or overlap."""
    step_i = np.flatnonzero(~starts[1:])  # consecutive scans of one run
    traj = np.stack([step_i, step_i + 1], axis=1)
    coo = affinity.tocoo() if hasattr(affinity, "tocoo") else None
    if coo is not None:
        rows, cols, vals = coo.row, coo.col, coo.data
    else:
        rows, cols = np.nonzero(np.asarray(affinity))
        vals = np.asarray(affinity)[rows, cols]
    keep = (rows < cols) & (vals > 0)
    over = np.stack([rows[keep], cols[keep]], axis=1).astype(np.intp)
    pairs = np.concatenate([traj, over], axis=0)
    kind = np.concatenate([np.zeros(len(traj), bool), np.ones(len(over), bool)])
    li, lj = labels[pairs[:, 0]], labels[pairs[:, 1]]
    cross = (li != lj) & (li >= 0) & (lj >= 0)
    return pairs[cross], kind[cross], np.stack([li[cross], lj[cross]], axis=1)


def build_topology(
    poses: np.ndarray,
    labels: np.ndarray,
    affinity,
    reference: np.ndarray,
    frames: np.ndarray,
    groups: ArrayLike | None = None,
) -> TopologicalMap:
    """Build the arcs between groups and their relative transformations (Section IV-A, step 4).

    Every scan pair ``(i, j)`` of groups ``a != b`` that is consecutive on the trajectory or has
    positive overlap gives one estimate of the pose of frame ``b`` in frame ``a``:
    ``q_i ⊕ d_ij ⊕ inverse(q_j)`` with ``q_i`` the pose of scan ``i`` in its local map,
    ``q_j`` likewise in ``b``, and ``d_ij`` the differential pose of ``j`` seen from ``i``. The
    arc holds the average of these estimates, translations averaged arithmetically and
    headings with the circular mean. When one global pose estimate gives both the local maps and
    the differential poses, every estimate is the same up to rounding and ``spread`` is ~0;
    they differ when local maps are refined independently.

    ``groups`` (the run of each scan, see ``run_starts_from_groups``): a scan where a new run
    begins is not joined to the scan before it by the trajectory (the last scan of one drive
    and the first of the next are not neighbours).

    Parameters
    ----------
    poses : ndarray of shape (N, 3)
        ``(x, y, yaw)`` of each scan.
    labels : ndarray of int, shape (N,)
        Group of each scan, -1 for none.
    affinity : ndarray or sparse matrix of shape (N, N)
        The scans' overlap; a positive entry joins its two scans.
    reference : ndarray of int, shape (K,)
        Each group's reference scan.
    frames : ndarray of shape (K, 3)
        World pose of each group's frame.
    groups : array-like of shape (N,), optional
        The run of each scan; default one run.

    Returns
    -------
    TopologicalMap
        The groups' frames and the arcs between them.
    """
    poses = check_poses(poses)
    labels = _check_labels(labels, poses.shape[0])
    if labels.size and labels.max() >= len(frames):
        raise ValueError(
            f"labels must be groups 0..{len(frames) - 1} of the {len(frames)} frames, got "
            f"{labels.max()}"
        )
    shape = affinity.shape if hasattr(affinity, "shape") else np.shape(affinity)  # sparse too
    if tuple(shape) != (poses.shape[0],) * 2:
        raise ValueError(
            f"affinity must be ({poses.shape[0]}, {poses.shape[0]}), one row and column per "
            f"pose, got {tuple(shape)}"
        )
    starts = run_starts_from_groups(groups, labels.shape[0])
    pairs, kind, glabels = _connecting_pairs(labels, affinity, starts)
    if pairs.size == 0:
        return TopologicalMap(reference, frames, [])
    a, b = glabels.min(axis=1), glabels.max(axis=1)
    # orient every pair from the lower group label to the higher one
    flip = glabels[:, 0] > glabels[:, 1]
    i = np.where(flip, pairs[:, 1], pairs[:, 0])
    j = np.where(flip, pairs[:, 0], pairs[:, 1])
    q_i = se2_relative(frames[a], poses[i])
    q_j = se2_relative(frames[b], poses[j])
    d_ij = se2_relative(poses[i], poses[j])
    estimates = se2_compose(se2_compose(q_i, d_ij), se2_inverse(q_j))
    # per-arc sums over its pairs (one bincount each instead of a loop over arcs)
    keys, arc = np.unique(a * (labels.max() + 1) + b, return_inverse=True)
    count = np.bincount(arc)

    def mean(values: np.ndarray) -> np.ndarray:
        return np.bincount(arc, weights=values) / count

    mx, my = mean(estimates[:, 0]), mean(estimates[:, 1])
    c, s = mean(np.cos(estimates[:, 2])), mean(np.sin(estimates[:, 2]))
    heading = np.arctan2(s, c)
    # spreads from deviations about the means (two passes: no cancellation when all agree)
    var = mean((estimates[:, 0] - mx[arc]) ** 2 + (estimates[:, 1] - my[arc]) ** 2)
    # mean resultant length, measured along the mean heading; circular std sqrt(-2 ln r)
    r = np.where(np.hypot(c, s) > 0, mean(np.cos(wrap_angle(estimates[:, 2] - heading[arc]))), 0)
    with np.errstate(divide="ignore"):
        circ = np.where(r > 0, np.sqrt(np.maximum(-2.0 * np.log(np.minimum(r, 1.0)), 0)), np.pi)
    by_traj = np.bincount(arc, weights=~kind) > 0
    by_over = np.bincount(arc, weights=kind) > 0
    n_groups = labels.max() + 1
    arcs = [
        TopologyArc(
            int(key // n_groups),
            int(key % n_groups),
            np.array([mx[k], my[k], heading[k]]),
            int(count[k]),
            frozenset(
                name for name, flag in (("trajectory", by_traj[k]), ("overlap", by_over[k])) if flag
            ),
            np.array([np.sqrt(var[k]), circ[k]]),
        )
        for k, key in enumerate(keys)
    ]
    return TopologicalMap(reference, frames, arcs)


def fill_from_nearest(labels: ArrayLike, starts: ArrayLike | None = None) -> np.ndarray:
    """Give each ``-1`` the label of the nearest labelled index (the earlier one on a tie).

    With ``starts`` (a boolean mask of run starts, one per label) the search stays inside each
    run; a run without any labelled index falls back to the search over all runs.

    Parameters
    ----------
    labels : array-like of int, shape (N,)
        Labels, -1 for none.
    starts : array-like of bool, shape (N,), optional
        True where a run begins.

    Returns
    -------
    ndarray of int, shape (N,)
        The labels with every -1 filled; all zeros when no index is labelled.
    """
    labels = _check_labels(labels)
    if starts is not None:
        starts = np.asarray(starts)
        if starts.dtype != bool or starts.shape != labels.shape:
            raise ValueError(
                f"starts must be a boolean mask of shape {labels.shape}, one per label, got "
                f"{starts.dtype} of shape {starts.shape}"
            )
    if starts is not None and starts[1:].any():
        out = labels.copy()
        bounds = np.append(np.flatnonzero(starts), labels.size)
        for lo, hi in itertools.pairwise(bounds):
            if (labels[lo:hi] >= 0).any():
                out[lo:hi] = _fill(labels[lo:hi])
        return _fill(out) if (out < 0).any() else out
    return _fill(labels)


def _fill(labels: np.ndarray) -> np.ndarray:
    """Run `fill_from_nearest` over all indices, on checked labels."""
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
