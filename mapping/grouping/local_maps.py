"""Local maps rebuilt from groups of scans, and how consistent they are (Blanco et al.'s claim).

The observation grouping exists to produce *consistent local maps* (paper, Sections I and V):
scans that see the same space go together, so aligning them gives a crisp map even where the
global poses have drifted. This module tests that claim for any labelling of the scans:

* ``align_group`` rebuilds one group's local map by scan-to-map ICP (each scan, in time order,
  aligned to the scans of its group already placed, seeded with the given relative motion);
* ``map_residuals`` measures a map's consistency: the distance from the points of each scan
  to the nearest point of every other scan of its map that sees the same surfaces (a crisp
  map has residuals at the sensor noise; a smeared one has doubled walls);
* ``localise_held_out`` localises scans left out of the maps against the local map of their
  group and against one global map, scored by the error of the pose relative to a neighbour
  scan in the map (so it needs no common world frame);
* ``submap_labels`` gives the simple baselines a user would pick instead of the grouping: a
  new submap every ``n`` scans or every ``d`` metres travelled.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from numbers import Integral

import numpy as np
from numpy.typing import ArrayLike
from scipy.spatial import cKDTree

from common.geometry import se2_compose, se2_relative, transform_points
from common.validation import is_real
from mapping.grouping.overlap import check_scans_and_poses
from mapping.grouping.topology import check_poses
from mapping.run_starts import run_starts_from_groups
from mapping.scan_matching import densify_scan, icp

__all__ = [
    "align_group",
    "align_groups",
    "localise_held_out",
    "map_residuals",
    "submap_labels",
]


def _is_integer(value) -> bool:
    """Check for an integer, not a bool (``True`` is an ``int`` to Python, not a count)."""
    return isinstance(value, Integral) and not isinstance(value, bool | np.bool_)


def _check_labels(labels: ArrayLike, n: int) -> np.ndarray:
    """Return ``labels`` as an array of shape ``(n,)`` of integer group ids (-1: no group)."""
    labels = np.asarray(labels)
    if labels.shape != (n,):
        raise ValueError(f"labels must have shape ({n},), one group per scan, got {labels.shape}")
    integral = labels.dtype.kind in "iu" or (
        labels.dtype.kind == "f" and np.all(np.isfinite(labels) & (labels == np.round(labels)))
    )
    if not integral:
        raise ValueError(f"labels must be integer group ids (-1: none), got dtype {labels.dtype}")
    return labels


def _check_indices(indices: ArrayLike, n: int, name: str) -> np.ndarray:
    """Return ``indices`` as a 1-D int array of scan indices in ``[0, n)``."""
    indices = np.asarray(indices)
    if indices.ndim != 1 or (indices.size and indices.dtype.kind not in "iu"):
        raise ValueError(f"{name} must be a 1-D array of scan indices, got {indices!r}")
    if indices.size and (indices.min() < 0 or indices.max() >= n):
        raise ValueError(f"{name} must index the {n} scans (0 to {n - 1}), got {indices!r}")
    return indices.astype(int)


def submap_labels(
    poses: ArrayLike,
    *,
    n_scans: int | None = None,
    distance: float | None = None,
    groups: ArrayLike | None = None,
) -> np.ndarray:
    """Label fixed-size submaps: a new one every ``n_scans`` scans or ``distance`` metres.

    A submap ends after ``n_scans`` scans, or once it spans more than ``distance`` metres of
    travel. Exactly one of ``n_scans`` and ``distance`` is given. A new drive (``groups``, as
    in ``ObservationGraphPartitioner.fit``) always starts a new submap.

    Parameters
    ----------
    poses : array-like of shape (N, 3)
        Finite ``(x, y, yaw)`` of each scan, in time order.
    n_scans : int, optional
        Scans per submap.
    distance : float, optional
        Metres of travel per submap.
    groups : array-like of shape (N,), optional
        The drive of each scan; None is one drive.

    Returns
    -------
    ndarray of int, shape (N,)
        Submap of each scan, numbered in time order from 0.

    Raises
    ------
    ValueError
        If ``poses`` is not finite of shape ``(N, 3)``, ``n_scans`` is not an integer >= 1
        (a bool is not), or ``distance`` is not a positive number.
    """
    poses = check_poses(poses)
    if (n_scans is None) == (distance is None):
        raise ValueError("give exactly one of n_scans and distance")
    if n_scans is not None and not (_is_integer(n_scans) and n_scans >= 1):
        raise ValueError(f"n_scans must be an integer >= 1, got {n_scans!r}")
    if distance is not None and not (
        is_real(distance) and math.isfinite(distance) and distance > 0
    ):
        raise ValueError(f"distance must be a positive number of metres, got {distance!r}")
    starts = run_starts_from_groups(groups, len(poses))
    labels = np.zeros(len(poses), dtype=int)
    label, count, travelled = 0, 0, 0.0
    for i in range(len(poses)):
        if i > 0:
            step = float(np.hypot(*(poses[i, :2] - poses[i - 1, :2])))
            travelled += 0.0 if starts[i] else step
            full = count >= n_scans if n_scans is not None else travelled > distance
            if starts[i] or full:
                label, count, travelled = label + 1, 0, 0.0
        labels[i] = label
        count += 1
    return labels


def align_group(
    scans: Sequence[np.ndarray],
    poses: ArrayLike,
    members: ArrayLike,
    *,
    max_correspondence_distance: float = 0.5,
    window: int = 10,
    min_overlap: float = 0.5,
) -> np.ndarray:
    """Rebuild one group's local map: scan-to-map ICP of its scans in time order.

    The first member keeps its pose. Every next member is seeded with the given relative
    motion from the previous member (``poses[prev] ⊖ poses[i]`` composed on the aligned pose
    of ``prev``) and aligned by ``mapping.scan_matching.icp`` to the points of the last ``window``
    members already placed (densified along each scan). A match that does not converge or
    pairs fewer than ``min_overlap`` of the scan's points keeps the seed.

    Parameters
    ----------
    scans : sequence of ndarray of shape (M, 2)
        Sensor-frame points of every scan.
    poses : array-like of shape (N, 3)
        Given ``(x, y, yaw)`` of every scan.
    members : array-like of int
        Indices of the group's scans.
    max_correspondence_distance : float, default 0.5
        ICP's initial correspondence gate in metres.
    window : int, default 10
        How many members already placed make the map each next member is aligned to.
    min_overlap : float, default 0.5
        Fraction of the scan's points ICP must pair for its result to be kept.

    Returns
    -------
    ndarray of shape (len(members), 3)
        Aligned poses of the members, in the frame of the given poses of the first member.

    Raises
    ------
    ValueError
        If scans and poses are invalid (``mapping.grouping.overlap.check_scans_and_poses``) or
        ``members`` are not indices of the scans.
    """
    scans, poses = check_scans_and_poses(scans, poses)
    members = _check_indices(members, len(scans), "members")
    return _align_group(scans, poses, members, max_correspondence_distance, window, min_overlap)


def _align_group(
    scans: list[np.ndarray],
    poses: np.ndarray,
    members: np.ndarray,
    max_correspondence_distance: float = 0.5,
    window: int = 10,
    min_overlap: float = 0.5,
) -> np.ndarray:
    """Run ``align_group`` on checked scans, poses and members."""
    members = np.sort(members)
    out = poses[members].copy()
    placed: list[np.ndarray] = []  # members' densified points, in the group's frame
    for k, i in enumerate(members):
        if k > 0:
            prev = members[k - 1]
            seed = se2_compose(out[k - 1], se2_relative(poses[prev], poses[i]))
            out[k] = seed
            target = np.concatenate(placed[-window:])
            if len(scans[i]) >= 10 and len(target) >= 10:
                res = icp(
                    scans[i], target, seed, max_correspondence_distance=max_correspondence_distance
                )
                if res.converged and res.n_matches >= min_overlap * len(scans[i]):
                    out[k] = res.transform
        placed.append(transform_points(out[k], densify_scan(scans[i])))
    return out


def align_groups(scans: Sequence[np.ndarray], poses: ArrayLike, labels: ArrayLike) -> np.ndarray:
    """Run ``align_group`` for every group of ``labels``; scans labelled -1 keep their pose.

    Parameters
    ----------
    scans : sequence of ndarray of shape (M, 2)
        Sensor-frame points of every scan.
    poses : array-like of shape (N, 3)
        Given ``(x, y, yaw)`` of every scan.
    labels : array-like of int, shape (N,)
        Group of each scan, -1 for none.

    Returns
    -------
    ndarray of shape (N, 3)
        All poses, each group's in its own frame.

    Raises
    ------
    ValueError
        If scans and poses are invalid (``mapping.grouping.overlap.check_scans_and_poses``) or
        ``labels`` is not one integer per scan.
    """
    scans, poses = check_scans_and_poses(scans, poses)
    labels = _check_labels(labels, len(scans))
    out = poses.copy()
    for g in np.unique(labels[labels >= 0]):
        members = np.flatnonzero(labels == g)
        out[members] = _align_group(scans, poses, members)
    return out


def map_residuals(
    scans: Sequence[np.ndarray],
    poses: ArrayLike,
    labels: ArrayLike,
    *,
    max_distance: float = 0.5,
    min_shared: float = 0.3,
    stride: int = 4,
) -> dict:
    """Measure the consistency (crispness) of maps by residuals between scan pairs.

    The residuals are point-to-nearest-point distances.

    For every ordered pair ``(i, j)`` of scans in the same map whose bounding boxes come within
    ``max_distance``, every ``stride``-th point of ``i`` is matched to its nearest point of
    ``j`` (densified along the scan, so the beam spacing does not count as error). A pair in
    which at least ``min_shared`` of those points lie within ``max_distance`` sees the same
    surfaces, and its residuals count. Pairs, not the map's union, are scored so that a map of
    many scans is not made to look crisp by its density: two views of one wall that disagree
    by 20 cm score 20 cm however many other scans lie between them.

    Parameters
    ----------
    scans : sequence of ndarray of shape (M, 2)
        Sensor-frame points of every scan.
    poses : array-like of shape (N, 3)
        ``(x, y, yaw)`` of every scan, in the frame of its map.
    labels : array-like of int, shape (N,)
        Map of each scan, -1 for none.
    max_distance : float, default 0.5
        Metres within which a point counts as matched.
    min_shared : float, default 0.3
        Fraction of sampled points within ``max_distance`` for a pair to share surfaces.
    stride : int, default 4
        Every ``stride``-th point of a scan is sampled.

    Returns
    -------
    dict
        ``mean_m``, ``median_m``, ``p90_m`` of the residuals within ``max_distance`` over all
        sharing pairs; ``pairs``: how many pairs share surfaces; ``matched``: the fraction of
        the sampled points of those pairs within ``max_distance``.

    Raises
    ------
    ValueError
        If scans and poses are invalid (``mapping.grouping.overlap.check_scans_and_poses``) or
        ``labels`` is not one integer per scan.
    """
    scans, poses = check_scans_and_poses(scans, poses)
    labels = _check_labels(labels, len(scans))
    world = [transform_points(poses[i], s) for i, s in enumerate(scans)]
    lo = np.array([w.min(axis=0) if len(w) else [np.inf] * 2 for w in world])
    hi = np.array([w.max(axis=0) if len(w) else [-np.inf] * 2 for w in world])
    residuals, pairs, sampled = [], 0, 0
    for g in np.unique(labels[labels >= 0]):
        members = np.flatnonzero(labels == g)
        if len(members) < 2:
            continue
        near = np.all(
            (lo[members, None] <= hi[None, members] + max_distance)
            & (lo[None, members] <= hi[members, None] + max_distance),
            axis=2,
        )
        np.fill_diagonal(near, False)
        for b, j in enumerate(members):
            sources = np.flatnonzero(near[:, b])
            if not len(sources):
                continue
            tree = cKDTree(transform_points(poses[j], densify_scan(scans[j])))
            for a in sources:
                pts = world[members[a]][::stride]
                d, _ = tree.query(pts, distance_upper_bound=max_distance)
                hit = np.isfinite(d)
                if len(pts) and hit.mean() >= min_shared:
                    residuals.append(d[hit])
                    pairs += 1
                    sampled += len(pts)
    res = np.concatenate(residuals) if residuals else np.empty(0)
    return {
        "mean_m": float(res.mean()) if res.size else None,
        "median_m": float(np.median(res)) if res.size else None,
        "p90_m": float(np.quantile(res, 0.9)) if res.size else None,
        "pairs": pairs,
        "matched": float(res.size / sampled) if sampled else None,
    }


def localise_held_out(
    scans: Sequence[np.ndarray],
    poses: ArrayLike,
    truth: ArrayLike,
    held_out: ArrayLike,
    anchor: ArrayLike,
    maps: dict[int, np.ndarray],
    map_of: ArrayLike,
    rng: np.random.Generator,
    *,
    init_sigma: tuple[float, float] = (0.2, 0.05),
    max_correspondence_distance: float = 0.5,
) -> np.ndarray:
    """Localise each held-out scan by ICP against a map; return the error of its relative pose.

    ``maps[m]`` is a point map (its scans' points at ``poses``: aligned local-map poses or
    global ones). Held-out scan ``held_out[j]`` is aligned to ``maps[map_of[j]]`` from its
    given pose ``poses[held_out[j]]`` perturbed by Gaussian noise of ``init_sigma`` (metres,
    radians; drawn from ``rng``), and its estimated pose is compared with the map scan
    ``anchor[j]`` (a neighbour in time, inside that map): the error is that of
    ``est ⊖ poses[anchor]`` against ``truth[anchor] ⊖ truth[held_out]``, so a map in its own
    frame is scored as fairly as one in the world frame.

    Parameters
    ----------
    scans : sequence of ndarray of shape (M, 2)
        Sensor-frame points of every scan.
    poses : array-like of shape (N, 3)
        Given ``(x, y, yaw)`` of every scan.
    truth : array-like of shape (N, 3)
        True poses of every scan.
    held_out : array-like of int
        Indices of the held-out scans.
    anchor : array-like of int
        For each held-out scan, a neighbour in its map.
    maps : dict of int to ndarray of shape (P, 2)
        Point map of each map id.
    map_of : array-like
        For each held-out scan, the map id to localise it in.
    rng : numpy.random.Generator
        Source of the initial pose noise.
    init_sigma : tuple of (float, float), default (0.2, 0.05)
        Noise on the initial pose: translation (m) and heading (rad).
    max_correspondence_distance : float, default 0.5
        ICP's initial correspondence gate in metres.

    Returns
    -------
    ndarray of shape (len(held_out), 2)
        Translation (m) and absolute heading (rad) error of each held-out scan; ``inf`` where
        ICP did not converge.

    Raises
    ------
    ValueError
        If scans and poses are invalid (``mapping.grouping.overlap.check_scans_and_poses``),
        ``truth`` is not finite and shaped as ``poses``, ``held_out`` and ``anchor`` are not indices
        of the scans of one length, or ``map_of`` has not one entry per held-out scan.
    """
    scans, poses = check_scans_and_poses(scans, poses)
    truth = np.asarray(truth, dtype=float)
    if truth.shape != poses.shape or not np.isfinite(truth).all():
        raise ValueError(f"truth must be finite poses of shape {poses.shape}, got {truth.shape}")
    held_out = _check_indices(held_out, len(scans), "held_out")
    anchor = _check_indices(anchor, len(scans), "anchor")
    map_of = np.asarray(map_of)
    if anchor.shape != held_out.shape or map_of.shape != held_out.shape:
        raise ValueError(
            f"held_out, anchor and map_of must have one entry per held-out scan, got shapes "
            f"{held_out.shape}, {anchor.shape} and {map_of.shape}"
        )
    trees = {m: cKDTree(p) for m, p in maps.items() if len(p) >= 10}
    sigma_t, sigma_r = init_sigma
    noise = rng.normal(size=(len(held_out), 3)) * np.array([sigma_t, sigma_t, sigma_r])
    errors = np.full((len(held_out), 2), np.inf)
    for j, (i, a) in enumerate(zip(held_out, anchor, strict=True)):
        tree = trees.get(map_of[j])
        if tree is None or len(scans[i]) < 10:
            continue
        res = icp(
            scans[i],
            tree.data,
            poses[i] + noise[j],
            max_correspondence_distance=max_correspondence_distance,
            target_tree=tree,
        )
        if not res.converged:
            continue
        est = se2_relative(poses[a], res.transform)
        true = se2_relative(truth[a], truth[i])
        dyaw = math.remainder(float(est[2] - true[2]), 2 * math.pi)
        errors[j] = [float(np.hypot(*(est[:2] - true[:2]))), abs(dyaw)]
    return errors
