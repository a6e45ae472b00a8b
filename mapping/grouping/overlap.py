"""Sensed-space overlap (SSO) of laser scans (Blanco et al., Section IV-A, eq. 16-18).

Two scans overlap as much as the fraction of their points that fall within ``delta`` of a point
of the other scan once both are placed in the world with their poses. The matched fraction
``Pi(i, j)`` (eq. 17) is not symmetric because the beam density falls with range, so the SSO is
the mean of both directions (eq. 18).
"""

from __future__ import annotations

from collections.abc import Iterable, Sequence

import numpy as np
import scipy.sparse as sp
from numpy.typing import ArrayLike
from scipy.spatial import cKDTree

from common.geometry import transform_points
from mapping.grouping.voxel_grid import (
    check_voxel_size,
    voxel_adjacency,
    voxel_incidence,
    voxel_offsets,
)

__all__ = [
    "check_scans_and_poses",
    "check_voxel_size",  # from mapping.grouping.voxel_grid, where the grid lives
    "sensed_space_overlap",
    "voxel_incidence",
    "voxel_offsets",
    "world_points",
]

_METHODS = ("auto", "per_scan", "global")
# Above this many points in all, the self-join's list of close point pairs (tens per point)
# costs more memory than it saves time; see the benchmark in docs/guides/observation-grouping.md.
GLOBAL_MAX_POINTS = 25_000


def check_scans_and_poses(
    scans: Sequence[ArrayLike], poses: ArrayLike
) -> tuple[list[np.ndarray], np.ndarray]:
    """Validate scans and poses, returning them as float arrays.

    Parameters
    ----------
    scans : sequence of array-like of shape (M, 2)
        Finite sensor-frame points of each scan; an empty scan is ``[]`` or any array without
        elements.
    poses : array-like of shape (N, 3)
        Finite ``(x, y, yaw)`` of each scan.

    Returns
    -------
    scans : list of ndarray of shape (M, 2)
        Each scan as floats; an empty one ``(0, 2)``.
    poses : ndarray of shape (N, 3)
        The poses as floats.

    Raises
    ------
    ValueError
        Naming ``scans`` or ``poses``: no scans, a scan not of shape ``(M, 2)``, non-finite
        values, ``poses`` not ``(N, 3)``, or different numbers of scans and poses.
    """
    if (
        scans is None
        or isinstance(scans, str | bytes)
        or not isinstance(scans, Iterable)
        or (isinstance(scans, np.ndarray) and scans.ndim == 0)
    ):
        raise ValueError(
            f"scans must be a sequence of (M, 2) point arrays, got {type(scans).__name__}"
        )
    if isinstance(scans, np.ndarray) and scans.ndim == 3:
        scans = list(scans)
    scans = [np.asarray(s, dtype=float) for s in scans]
    if len(scans) == 0:
        raise ValueError("scans is empty; need at least one scan")
    for i, s in enumerate(scans):
        if s.size == 0:
            scans[i] = s.reshape(0, 2)
            continue
        if s.ndim != 2 or s.shape[1] != 2:
            raise ValueError(f"scans[{i}] must have shape (M, 2), got {s.shape}")
        if not np.isfinite(s).all():
            raise ValueError(
                f"scans[{i}] contains NaN or inf; drop missed beams before calling "
                "(an all-missed scan is an empty (0, 2) array)"
            )
    poses = np.asarray(poses, dtype=float)
    if poses.ndim != 2 or poses.shape[1] != 3:
        raise ValueError(f"poses must have shape (N, 3) of (x, y, yaw), got {poses.shape}")
    if poses.shape[0] != len(scans):
        raise ValueError(
            f"poses and scans must have the same length, got {poses.shape[0]} poses "
            f"and {len(scans)} scans"
        )
    if not np.isfinite(poses).all():
        bad = np.flatnonzero(~np.isfinite(poses).all(axis=1))
        raise ValueError(f"poses contains NaN or inf (rows {bad[:5].tolist()})")
    return scans, poses


def world_points(scans: Sequence[np.ndarray], poses: np.ndarray) -> list[np.ndarray]:
    """Map each scan's points to the world frame with its pose.

    Parameters
    ----------
    scans : sequence of ndarray of shape (M, 2)
        Sensor-frame points of each scan.
    poses : ndarray of shape (N, 3)
        ``(x, y, yaw)`` of each scan.

    Returns
    -------
    list of ndarray of shape (M, 2)
        Each scan's points in the world frame.
    """
    return [transform_points(p, s) for p, s in zip(poses, scans, strict=True)]


def _candidate_pairs(lo: np.ndarray, hi: np.ndarray, reach: float) -> np.ndarray:
    """Return pairs ``(i, j)``, ``i < j``, whose bounding boxes, grown by ``reach``, intersect.

    A KD-tree over the box centres gives a superset (circles around the boxes) without an
    all-pairs loop; the exact box test then filters it.
    """
    if len(lo) < 2:
        return np.empty((0, 2), dtype=np.intp)
    centres, half = (lo + hi) / 2, (hi - lo) / 2
    radius = np.linalg.norm(half, axis=1)
    pairs = cKDTree(centres).query_pairs(2.0 * radius.max() + reach, output_type="ndarray")
    i, j = pairs[:, 0], pairs[:, 1]
    gap = np.abs(centres[i] - centres[j]) - half[i] - half[j]
    return pairs[np.all(gap <= reach, axis=1)]


def _fractions_per_scan(
    pts: list[np.ndarray], delta: float, workers: int
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Return matched fractions ``Pi(i, j)`` (eq. 17) with one KD-tree per target scan ``j``.

    Memory grows with the number of candidate pairs only. Returns ``(i, j, Pi(i, j))`` for
    every candidate pair in both directions.
    """
    sizes = np.array([len(p) for p in pts])
    all_pts = np.concatenate(pts)
    offsets = np.concatenate([[0], np.cumsum(sizes)])
    lo = np.minimum.reduceat(all_pts, offsets[:-1], axis=0)
    hi = np.maximum.reduceat(all_pts, offsets[:-1], axis=0)
    pairs = _candidate_pairs(lo, hi, delta)
    # both directions: Pi(i, j) queries i's points against j's tree
    src = np.concatenate([pairs[:, 0], pairs[:, 1]])
    dst = np.concatenate([pairs[:, 1], pairs[:, 0]])
    order = np.lexsort((src, dst))
    src, dst = src[order], dst[order]
    starts = np.searchsorted(dst, np.arange(len(pts) + 1))
    pi_vals = np.empty(len(src))
    xs, ys = all_pts[:, 0].copy(), all_pts[:, 1].copy()  # contiguous columns: faster tests
    lo_d, hi_d = lo - delta, hi + delta
    # cKDTree's distance_upper_bound is strict; eq. 16 matches at exactly delta too
    bound = np.nextafter(delta, np.inf)
    for j in range(len(pts)):
        a, b = starts[j], starts[j + 1]
        if a == b:
            continue
        cand = src[a:b]
        counts = sizes[cand]
        # indices of every candidate scan's points, gathered without a Python loop
        idx = np.repeat(offsets[cand] - np.cumsum(counts) + counts, counts)
        idx += np.arange(idx.size)
        qx, qy = xs[idx], ys[idx]
        # a point outside j's box grown by delta cannot match: skip its tree query
        near = np.flatnonzero(
            (qx >= lo_d[j, 0]) & (qx <= hi_d[j, 0]) & (qy >= lo_d[j, 1]) & (qy <= hi_d[j, 1])
        )
        matched = np.zeros(idx.size)
        if near.size:
            d, _ = cKDTree(pts[j]).query(
                all_pts[idx[near]], k=1, distance_upper_bound=bound, workers=workers
            )
            matched[near] = np.isfinite(d)
        owner = np.repeat(np.arange(cand.size), counts)
        pi_vals[a:b] = np.bincount(owner, weights=matched, minlength=cand.size) / counts
    return src, dst, pi_vals


def _fractions_global(
    pts: list[np.ndarray], delta: float, workers: int
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Return matched fractions ``Pi(i, j)`` (eq. 17) from one KD-tree over all points.

    A single self-join (``query_pairs``, inclusive radius as eq. 16) lists every point pair
    within ``delta``; a sparse (point, scan) incidence removes the duplicates (several points of
    ``j`` near the same point of ``i`` count once). Faster than per-scan trees for small maps,
    but memory grows with the number of close point pairs. ``workers`` is unused (the self-join
    is single-threaded).
    """
    sizes = np.array([len(p) for p in pts])
    n, n_pts = len(pts), int(sizes.sum())
    owner = np.repeat(np.arange(n), sizes)
    close = cKDTree(np.concatenate(pts)).query_pairs(delta, output_type="ndarray")
    a, b = close[:, 0], close[:, 1]
    cross = owner[a] != owner[b]
    a, b = a[cross], b[cross]
    # incidence[p, j] = 1 if scan j has a point within delta of point p (duplicates summed)
    incidence = sp.csr_array(
        (np.ones(2 * a.size), (np.concatenate([a, b]), owner[np.concatenate([b, a])])),
        shape=(n_pts, n),
    )
    # rows of one scan are contiguous: count each (scan i, scan j) once per matched point
    scan_of_entry = np.repeat(owner, np.diff(incidence.indptr))
    counts = sp.coo_array(
        (np.ones(incidence.nnz), (scan_of_entry, incidence.indices)), shape=(n, n)
    ).tocsr()
    counts.sum_duplicates()
    counts = counts.tocoo()
    return counts.row, counts.col, counts.data / sizes[counts.row]


def _fractions_voxel(
    pts: list[np.ndarray], delta: float, voxel_size: float
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Return matched fractions ``Pi(i, j)`` (eq. 17) of the voxel-downsampled scans.

    Every scan becomes the set of voxels its points fall in (``A``); voxel ``u`` of scan ``i``
    matches scan ``j`` when a voxel of ``j`` lies within ``delta`` of it, centre to centre
    (eq. 16 on the grid). With ``K`` the voxel adjacency of that disc, ``D = A K`` (binarised)
    marks the voxels near each scan, and ``A D^T`` counts the matched voxels of every pair at
    once: two sparse products, no loop over scans or pairs.
    """
    A, grid = voxel_incidence(pts, voxel_size)
    K = voxel_adjacency(grid, voxel_offsets(delta / voxel_size))
    occupied = A.copy()
    occupied.data[:] = 1.0
    near = occupied @ K
    near.data[:] = 1.0
    counts = (A @ near.T).tocoo()
    n_points = np.asarray(A.sum(axis=1)).ravel()
    return counts.row, counts.col, counts.data / n_points[counts.row]


def sensed_space_overlap(
    scans: Sequence[ArrayLike],
    poses: ArrayLike,
    delta: float,
    *,
    sparse: bool = False,
    method: str = "auto",
    workers: int = 1,
    voxel_size: float | None = None,
) -> np.ndarray | sp.csr_array:
    """Return the sensed-space-overlap matrix of laser scans (eq. 16-18).

    ``C(p, q, delta) = 1`` when ``||p - q|| <= delta`` (eq. 16); ``Pi(i, j)`` is the fraction of
    the ``M_i`` points of scan ``i`` with some point of scan ``j`` within ``delta`` (eq. 17);
    ``Psi(i, j) = (Pi(i, j) + Pi(j, i)) / 2`` (eq. 18).

    Two exact methods give the same matrix. ``"per_scan"`` builds one KD-tree per scan and,
    for every scan ``j``, queries all candidate points of the other scans against it in one
    batch; pairs whose world-frame bounding boxes are more than ``delta`` apart are skipped, as
    are points of ``i`` outside ``j``'s box grown by ``delta`` (they cannot match), so memory
    and time grow with the overlapping pairs only. ``"global"`` self-joins one KD-tree over all
    points; it avoids the per-scan Python loop, which is ~2x faster for small maps, but its
    memory grows with the number of close point pairs.

    With ``voxel_size`` the scans are first downsampled to a voxel grid shared by all scans (as
    MRPT's map partitioner does): each scan becomes the voxels its points fall in, and eq. 16-18
    are applied to the voxel centres, with the ``delta`` disc on the grid. ``Pi(i, j)`` then
    counts voxels rather than points, so the many beams that hit a nearby wall count once per
    voxel; snapping moves a point by at most ``voxel_size / sqrt(2)``. Two sparse matrix
    products give all pairs at once (``_fractions_voxel``), much faster than the exact methods
    on long or dense logs.

    Parameters
    ----------
    scans : sequence of array-like of shape (M_i, 2)
        Points in each sensor frame (x forward, y left). ``M_i`` may be 0 (all beams missed).
        Must be finite: drop missed beams instead of marking them NaN.
    poses : array-like of shape (N, 3)
        World pose ``(x, y, yaw)`` of the sensor for each scan.
    delta : float
        Matching tolerance in metres, ``> 0`` (a parameter of the matching, not of the
        grouping; footnote 3).
    sparse : bool, default False
        Return a ``scipy.sparse.csr_array`` holding only the non-zero overlaps.
    method : {"auto", "per_scan", "global"}, default "auto"
        ``"auto"`` uses ``"global"`` up to ``GLOBAL_MAX_POINTS`` points in all, else
        ``"per_scan"``.
    workers : int, default 1
        Threads for the per-scan KD-tree queries (``-1``: all cores); small batches gain little.
    voxel_size : float, optional
        Side of the voxels in metres, in ``[delta / voxel_grid.MAX_DISC_RADIUS, delta]``; ``None``
        (default) computes eq. 16-18 exactly on the points with ``method``.

    Returns
    -------
    ndarray or csr_array of shape (N, N)
        Symmetric, values in ``[0, 1]``. The diagonal is 1 for every scan with points
        (reflexivity, Section III). An empty scan overlaps nothing, itself included: its row,
        column and diagonal entry are 0.

    Raises
    ------
    ValueError
        If ``delta`` is not a positive finite number, ``method`` is unknown, ``voxel_size`` is
        out of range (``check_voxel_size``) or too small for the extent of the points (voxel
        coordinates beyond ``voxel_grid.CELL_MAX``), or scans/poses are invalid (see
        ``check_scans_and_poses``).
    """
    if method not in _METHODS:
        raise ValueError(f"method must be one of {_METHODS}, got {method!r}")
    if not np.isscalar(delta) or not np.isfinite(delta) or delta <= 0:
        raise ValueError(f"delta must be a positive finite distance in metres, got {delta!r}")
    check_voxel_size(delta, voxel_size)
    scans, poses = check_scans_and_poses(scans, poses)
    n = len(scans)
    pts = world_points(scans, poses)
    sizes = np.array([len(p) for p in pts])
    nonempty = np.flatnonzero(sizes > 0)

    rows, cols, vals = [], [], []
    if len(nonempty) > 1:
        kept = [pts[i] for i in nonempty]
        if voxel_size is not None:
            src, dst, pi_vals = _fractions_voxel(kept, float(delta), float(voxel_size))
            cross = src != dst  # the unit diagonal is added below
            src, dst, pi_vals = src[cross], dst[cross], pi_vals[cross]
        else:
            if method == "auto":
                method = "global" if sizes.sum() <= GLOBAL_MAX_POINTS else "per_scan"
            fractions = _fractions_global if method == "global" else _fractions_per_scan
            src, dst, pi_vals = fractions(kept, float(delta), workers)
        # eq. 18: Psi = (Pi(i, j) + Pi(j, i)) / 2; the COO sums both halves into one entry
        rows += [nonempty[src], nonempty[dst]]
        cols += [nonempty[dst], nonempty[src]]
        vals += [0.5 * pi_vals, 0.5 * pi_vals]
    rows.append(nonempty)
    cols.append(nonempty)
    vals.append(np.ones(len(nonempty)))
    r, c, v = np.concatenate(rows), np.concatenate(cols), np.concatenate(vals)
    keep = v > 0
    w = sp.coo_array((v[keep], (r[keep], c[keep])), shape=(n, n)).tocsr()
    w.sum_duplicates()
    return w if sparse else w.toarray()
