"""Incremental observation grouping: scans added as the robot drives (``partial_fit``).

MRPT's incremental map partitioner adds each new observation to the graph, computes its
weights to the observations already there, and re-partitions only the part of the graph the
new node touches. ``ObservationGraphPartitioner.partial_fit`` does the same with:

- ``VoxelOverlapIndex`` keeps every scan as its voxel cells with point counts (the grid of
  ``mapping.grouping.overlap.sensed_space_overlap`` with ``voxel_size``) and gives a new scan's
  overlaps (eq. 16-18 on the voxel grid) to the scans whose poses are within reach (a KD-tree
  on the poses), so the weights are the same numbers the batch overlap computes.
- The groups the new scan overlaps are merged with it and partitioned again by the recursive
  min-Ncut (``mapping.grouping.normalized_cut``); the other groups stay as they are.
"""

from __future__ import annotations

import numpy as np
import scipy.sparse as sp
from scipy.spatial import cKDTree

from common.geometry import transform_points
from common.validation import is_real
from mapping.grouping.normalized_cut import partition_checked
from mapping.grouping.overlap import check_scans_and_poses, check_voxel_size, voxel_offsets

__all__ = ["VoxelOverlapIndex", "add_scans", "repartition"]

# voxel (ix, iy) -> one int64 key; iy is offset so that negative cells keep their order
_Y_BITS = 32
_Y_OFFSET = 1 << (_Y_BITS - 1)
# voxel coordinates (either sign) the keys hold with room for the dilation's shifts
_CELL_MAX = 1 << (_Y_BITS - 2)


class VoxelOverlapIndex:
    """Scans as voxel cells with point counts, for the overlap of each new scan.

    Parameters
    ----------
    delta, voxel_size : float
        Match tolerance and voxel side in metres, as in ``sensed_space_overlap``: delta
        positive and finite, voxel_size in ``[delta / MAX_DISC_RADIUS, delta]``.

    Attributes
    ----------
    delta, voxel_size : float
        The parameters.
    keys, counts : list of ndarray
        Per indexed scan: its sorted voxel keys and the points in each voxel.
    n_points : list of int
        Per indexed scan: its points' count.
    centres : list of ndarray of shape (2,)
        Per indexed scan: the sensor's position.
    reach : list of float
        Per indexed scan: its farthest point from the sensor, in metres.

    Examples
    --------
    >>> import numpy as np
    >>> from mapping.grouping import VoxelOverlapIndex
    >>> wall = np.c_[np.full(50, 2.0), np.linspace(-1.0, 1.0, 50)]
    >>> index = VoxelOverlapIndex(delta=0.1, voxel_size=0.05)
    >>> index.add(wall, np.zeros(3))[0].tolist()
    []
    >>> indices, weights = index.add(wall, np.zeros(3))
    >>> indices.tolist(), weights.round(2).tolist()
    ([0], [1.0])

    See Also
    --------
    mapping.grouping.sensed_space_overlap : The whole matrix at once, on points or voxels.
    mapping.grouping.ObservationGraphPartitioner : The estimator these weights feed.
    """

    def __init__(self, delta: float, voxel_size: float) -> None:
        if not (is_real(delta) and 0 < delta < np.inf):
            raise ValueError(f"delta must be a positive finite number (metres), got {delta!r}")
        if not (is_real(voxel_size) and 0 < voxel_size <= delta):  # None is no voxel here
            raise ValueError(
                f"voxel_size must be a number in (0, delta = {delta}], got {voxel_size!r}"
            )
        check_voxel_size(delta, voxel_size)  # and not so fine that the disc is too large
        self.delta = delta
        self.voxel_size = voxel_size
        off = voxel_offsets(delta / voxel_size)
        self._shifts = np.sort(off[:, 0] * (1 << _Y_BITS) + off[:, 1])
        self.keys: list[np.ndarray] = []  # sorted unique cell keys per scan
        self.counts: list[np.ndarray] = []  # points per cell
        self.n_points: list[int] = []
        self.centres: list[np.ndarray] = []  # sensor position per scan
        self.reach: list[float] = []  # farthest point from the sensor

    def __len__(self) -> int:
        """Return the number of indexed scans."""
        return len(self.keys)

    def add(self, points: np.ndarray, pose: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Add a scan (sensor-frame points at ``pose``) and return its overlaps.

        The overlaps are ``Psi`` (eq. 18) with the scans already indexed, as
        ``(indices, weights)`` with weights > 0.

        Parameters
        ----------
        points : ndarray of shape (M, 2)
            Finite sensor-frame points (``(0, 2)`` for a scan without returns).
        pose : ndarray of shape (3,)
            Finite ``(x, y, yaw)`` of the sensor.

        Returns
        -------
        indices : ndarray of int
            Indexed scans the new one overlaps, ascending.
        weights : ndarray of float
            Their overlaps ``Psi`` with the new scan, in (0, 1].
        """
        points, pose = _check_scan(points, pose)
        world = transform_points(pose, points)
        cells = np.floor(world / self.voxel_size)
        if cells.size and not np.abs(cells).max() < _CELL_MAX:
            raise ValueError(
                f"points: voxel coordinates beyond {_CELL_MAX} cells of {self.voxel_size} m at "
                f"this pose (a point far outside the map?); the index holds |x|, |y| below "
                f"{_CELL_MAX * self.voxel_size:.3g} m"
            )
        cells = cells.astype(np.int64)
        key = cells[:, 0] * (1 << _Y_BITS) + (cells[:, 1] + _Y_OFFSET)
        keys, counts = np.unique(key, return_counts=True)
        reach = float(np.hypot(points[:, 0], points[:, 1]).max()) if len(points) else 0.0
        out = self._overlaps(keys, counts, pose, len(points), reach)
        self.keys.append(keys)
        self.counts.append(counts)
        self.n_points.append(len(points))
        self.centres.append(np.asarray(pose[:2], dtype=float))
        self.reach.append(reach)
        return out

    def _overlaps(self, keys, counts, pose, n_points, reach) -> tuple[np.ndarray, np.ndarray]:
        empty = (np.empty(0, dtype=np.intp), np.empty(0))
        if not len(self) or n_points == 0:
            return empty
        # candidates by pose and range: a scan whose sensor is farther than both scans' reach
        # plus delta (and a voxel diagonal of snapping) cannot share a matched point
        radius = reach + max(self.reach) + self.delta + 2 * self.voxel_size
        cand = cKDTree(np.asarray(self.centres)).query_ball_point(pose[:2], radius)
        cand = np.array(sorted(j for j in cand if self.n_points[j] > 0), dtype=np.intp)
        if cand.size == 0:
            return empty
        # the cells within delta of this scan (its dilation), and which of them each
        # neighbouring (scan u -> cell u + shift) comes from
        grown = keys[:, None] + self._shifts[None, :]
        near, near_inv = np.unique(grown, return_inverse=True)
        near_inv = near_inv.reshape(grown.shape)
        sizes = np.array([len(self.keys[j]) for j in cand])
        ckeys = np.concatenate([self.keys[j] for j in cand])
        ccounts = np.concatenate([self.counts[j] for j in cand])
        owner = np.repeat(np.arange(cand.size), sizes)
        pos = np.minimum(np.searchsorted(near, ckeys), len(near) - 1)
        hit = near[pos] == ckeys
        # Pi(j, new): points of j within delta of the new scan
        pi_old = np.bincount(owner[hit], weights=ccounts[hit], minlength=cand.size)
        # with no hit at all (no shared voxel: the robot turned round) bincount gives int64
        pi_old = pi_old.astype(float, copy=False)
        pi_old /= np.array([self.n_points[j] for j in cand], dtype=float)
        # Pi(new, j): cells u of the new scan with some cell of j in u's dilation
        occupied = sp.csr_array(
            (np.ones(int(hit.sum())), (owner[hit], pos[hit])), shape=(cand.size, len(near))
        )
        dilation = sp.csr_array(
            (
                np.ones(grown.size),
                (np.repeat(np.arange(len(keys)), grown.shape[1]), near_inv.ravel()),
            ),
            shape=(len(keys), len(near)),
        )
        matched = (dilation @ occupied.T).tocsc()
        matched.data[:] = 1.0
        pi_new = (counts.astype(float) @ matched) / n_points
        psi = 0.5 * (np.asarray(pi_new).ravel() + pi_old)
        keep = psi > 0
        return cand[keep], psi[keep]


def _check_scan(points, pose) -> tuple[np.ndarray, np.ndarray]:
    """Return one scan and its pose as float arrays, checked as ``partial_fit`` checks a batch."""
    try:
        pose = np.asarray(pose, dtype=float)
    except (TypeError, ValueError):
        pose = np.empty(0)  # not numbers: refused below
    if pose.shape != (3,):
        raise ValueError(f"pose must have shape (3,) of (x, y, yaw), got {pose.shape}")
    try:
        scans, poses = check_scans_and_poses([points], pose[None])
    except ValueError as err:  # its messages name the batch's scans[0] and poses
        raise ValueError(str(err).replace("scans[0]", "points").replace("poses", "pose")) from None
    return scans[0], poses[0]


def add_scans(
    state: dict, scans: list, poses: np.ndarray, **ncut
) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """Add ``scans`` at ``poses`` one by one to the graph of ``state``; re-partition after each.

    Parameters
    ----------
    state : dict
        The graph: its ``index`` (a ``VoxelOverlapIndex``), ``arcs`` (a sequence of
        ``(rows, cols, vals)`` parts) and raw labels ``raw`` (-1 for empty scans).
    scans : list of ndarray of shape (M, 2)
        Sensor-frame points of each new scan.
    poses : ndarray of shape (n, 3)
        ``(x, y, yaw)`` of each new scan.
    **ncut
        Options of the recursive min-Ncut, as ``repartition`` takes them.

    Returns
    -------
    rows, cols, vals : ndarray
        The graph's arcs, a COO with both directions and the diagonal.
    raw : ndarray of int
        The raw labels of every scan, -1 for empty scans.
    """
    rows, cols, vals = (np.concatenate(part) for part in zip(*state["arcs"], strict=True))
    raw = state["raw"]
    for points, pose in zip(scans, poses, strict=True):
        new = raw.size
        idx, w = state["index"].add(points, pose)
        own = np.array([new] if len(points) else [], dtype=np.intp)
        rows = np.concatenate([rows, np.full(idx.size, new), idx, own])
        cols = np.concatenate([cols, idx, np.full(idx.size, new), own])
        vals = np.concatenate([vals, w, w, np.ones(own.size)])
        raw = np.append(raw, -1)
        if len(points):
            raw = repartition(raw, rows, cols, vals, new, idx, **ncut)
    return rows, cols, vals, raw


def repartition(
    labels: np.ndarray,
    rows: np.ndarray,
    cols: np.ndarray,
    vals: np.ndarray,
    new: int,
    neighbours: np.ndarray,
    **ncut,
) -> np.ndarray:
    """Return the labels after adding scan ``new`` to the graph.

    The groups that share an arc with the new scan are merged with it and partitioned again
    (``recursive_ncut_partition`` with ``ncut``'s options) on their own subgraph; every other
    group keeps its scans. Groups are renumbered in order of their first scan, as in ``fit``.

    Parameters
    ----------
    labels : ndarray of int
        Current labels, -1 for ``new`` (and for empty scans).
    rows, cols, vals : ndarray
        The graph's arcs, both directions and the diagonal, as a COO.
    new : int
        Index of the new scan.
    neighbours : ndarray of int
        The scans the new one overlaps.
    **ncut
        ``threshold``, ``assoc``, ``laplacian``, ``min_size`` and ``solver`` of the min-Ncut.

    Returns
    -------
    ndarray of int
        The new labels, ``0..K-1`` in order of each group's first scan; -1 stays -1.
    """
    affected = np.unique(labels[neighbours])
    affected = affected[affected >= 0]
    nodes = np.union1d(np.flatnonzero(np.isin(labels, affected)), [new])
    local = np.full(labels.size, -1, dtype=np.intp)
    local[nodes] = np.arange(nodes.size)
    inside = (local[rows] >= 0) & (local[cols] >= 0)
    W = sp.csr_array(
        (vals[inside], (local[rows[inside]], local[cols[inside]])), shape=(nodes.size,) * 2
    )
    o = ncut
    sub_labels, _ = partition_checked(
        W, o["threshold"], o["assoc"], o["laplacian"], o["min_size"], o["solver"]
    )
    out = labels.copy()
    out[nodes] = labels.max() + 1 + sub_labels
    return _renumber(out)


def _renumber(labels: np.ndarray) -> np.ndarray:
    """Return labels ``0..K-1`` in order of each group's first index (-1 stays -1)."""
    out = np.full_like(labels, -1)
    valid = labels >= 0
    _, first = np.unique(labels[valid], return_index=True)
    order = np.argsort(first)
    rank = np.empty_like(order)
    rank[order] = np.arange(order.size)
    _, inverse = np.unique(labels[valid], return_inverse=True)
    out[valid] = rank[inverse]
    return out
