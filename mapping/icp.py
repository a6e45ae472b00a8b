"""Point-to-point ICP in SE(2) and the scan-matching refinement of odometry poses.

The observation grouping of Blanco et al. assumes the poses come from a map builder (Section
IV-A); with raw odometry, heading drift smears the sensed-space overlap. ``refine_poses``
replaces each odometry increment by the ICP alignment of consecutive scans, seeded with that
increment, before the overlap is computed.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike
from scipy.spatial import cKDTree

from mapping.topology import run_starts_from_groups, se2_compose, se2_relative

__all__ = ["IcpResult", "densify_scan", "icp", "refine_poses"]


@dataclass(frozen=True)
class IcpResult:
    """Outcome of ``icp``.

    Attributes
    ----------
    transform : ndarray of shape (3,)
        Pose ``(x, y, yaw)`` of the source frame in the target frame: ``transform_points(
        transform, source)`` lies on ``target``.
    rmse : float
        Root-mean-square distance of the final correspondences.
    n_matches : int
        Correspondences within ``max_correspondence_distance`` at the last iteration.
    n_iterations : int
    converged : bool
        The update fell below ``tolerance`` with at least ``min_matches`` correspondences.
    """

    transform: np.ndarray
    rmse: float
    n_matches: int
    n_iterations: int
    converged: bool


def _kabsch_2d(p: np.ndarray, q: np.ndarray) -> tuple[float, float, float]:
    """Least-squares rigid motion ``(x, y, yaw)`` taking points ``p`` onto ``q``.

    In 2-D the SVD solution of the Kabsch/Umeyama problem has a closed form: the rotation
    angle is ``atan2(sum(p' x q'), sum(p' . q'))`` of the centred points, always a proper
    rotation; one ``atan2`` instead of an SVD per ICP iteration. The centred sums come from
    one 2x2 product (``p^T q - n pc qc^T``): ICP calls this every iteration, and per-call
    overhead, not arithmetic, is what it costs.
    """
    n = len(p)
    pc, qc = p.sum(axis=0) / n, q.sum(axis=0) / n
    h = p.T @ q - n * np.outer(pc, qc)
    theta = math.atan2(float(h[0, 1] - h[1, 0]), float(h[0, 0] + h[1, 1]))
    c, s = math.cos(theta), math.sin(theta)
    px, py, qx, qy = float(pc[0]), float(pc[1]), float(qc[0]), float(qc[1])
    return qx - (c * px - s * py), qy - (s * px + c * py), theta


def icp(
    source: ArrayLike,
    target: ArrayLike,
    init: ArrayLike | None = None,
    *,
    max_correspondence_distance: float = 0.5,
    min_correspondence_distance: float = 0.05,
    max_iterations: int = 50,
    tolerance: float = 1e-6,
    min_matches: int = 10,
    target_tree: cKDTree | None = None,
) -> IcpResult:
    """Align ``source`` points to ``target`` points with point-to-point ICP.

    Each iteration pairs every transformed source point with its nearest target point (one
    vectorised KD-tree query), drops pairs farther than ``max_correspondence_distance``, and
    keeps those within an adaptive gate, and solves the rigid motion in closed form (SVD of
    the cross-covariance).

    Parameters
    ----------
    source, target : array-like of shape (M, 2), (K, 2)
    init : array-like of shape (3,), optional
        Initial guess of the result's ``transform`` (e.g. the odometry increment).
    max_correspondence_distance : float, default 0.5
        Initial correspondence gate in metres; must be positive.
    min_correspondence_distance : float, default 0.05
        The gate then shrinks to three times the median residual, but not below this.
    max_iterations : int, default 50
    tolerance : float, default 1e-6
        Stop when the update's translation (m) and rotation (rad) are both below this.
    min_matches : int, default 10
        Fewer correspondences than this stops the iteration unconverged.
    target_tree : cKDTree, optional
        A tree already built on ``target``.

    Returns
    -------
    IcpResult
    """
    source = np.asarray(source, dtype=float).reshape(-1, 2)
    target = np.asarray(target, dtype=float).reshape(-1, 2)
    if not max_correspondence_distance > 0:
        raise ValueError(
            f"max_correspondence_distance must be positive, got {max_correspondence_distance!r}"
        )
    T = np.zeros(3) if init is None else np.asarray(init, dtype=float).copy()
    if len(source) < min_matches or len(target) < min_matches:
        return IcpResult(T, np.inf, 0, 0, False)
    tree = cKDTree(target) if target_tree is None else target_tree
    # the pose is kept as scalars and composed by hand: with a few hundred points per scan,
    # array helpers' overhead per iteration costs as much as the KD-tree query
    x, y, yaw = (float(v) for v in T)
    n_matches, rmse = 0, np.inf
    for it in range(1, max_iterations + 1):
        c, s = math.cos(yaw), math.sin(yaw)
        moved = source @ np.array([[c, s], [-s, c]]) + (x, y)
        d, idx = tree.query(moved, k=1, distance_upper_bound=max_correspondence_distance)
        ok = np.isfinite(d)
        n_matches = int(np.count_nonzero(ok))
        if n_matches < min_matches:
            return IcpResult(np.array([x, y, yaw]), np.inf, n_matches, it, False)
        # adaptive gate: pairs far beyond the typical residual are points without a
        # counterpart (newly seen structure); they would drag the solution
        gate = max(3.0 * _median(d[ok]), min_correspondence_distance)
        ok &= d <= gate
        dk = d[ok]
        rmse = math.sqrt(float(dk @ dk) / len(dk))
        sx, sy, syaw = _kabsch_2d(moved[ok], target[idx[ok]])
        # T <- step ⊕ T (mapping.topology.se2_compose, on scalars)
        cs, ss = math.cos(syaw), math.sin(syaw)
        x, y = sx + cs * x - ss * y, sy + ss * x + cs * y
        yaw = (yaw + syaw + math.pi) % (2.0 * math.pi) - math.pi
        if math.hypot(sx, sy) < tolerance and abs(syaw) < tolerance:
            return IcpResult(np.array([x, y, yaw]), rmse, n_matches, it, True)
    return IcpResult(np.array([x, y, yaw]), rmse, n_matches, max_iterations, False)


def _median(values: np.ndarray) -> float:
    """``np.median`` of a non-empty 1-D array, without its dispatch overhead."""
    n = len(values)
    k = n // 2
    if n % 2:
        return float(np.partition(values, k)[k])
    part = np.partition(values, (k - 1, k))
    return 0.5 * float(part[k - 1] + part[k])


def densify_scan(points: np.ndarray, spacing: float = 0.02, max_gap: float = 0.3) -> np.ndarray:
    """Fill the gaps between consecutive beam points with points every ``spacing`` metres.

    Point-to-point ICP between two sparse scans pairs points that are not the same spot (the
    beams hit the wall at different places), which biases the alignment by up to the beam
    spacing. Densifying the target along the scan polyline removes most of that bias while
    keeping the SVD solution. Gaps wider than ``max_gap`` (depth jumps, door edges) are not
    filled.
    """
    points = np.asarray(points, dtype=float).reshape(-1, 2)
    if len(points) < 2:
        return points
    seg = np.diff(points, axis=0)
    length = np.hypot(seg[:, 0], seg[:, 1])
    n_fill = np.where(length <= max_gap, np.ceil(length / spacing).astype(int), 1)
    n_fill = np.maximum(n_fill, 1)
    start = np.repeat(np.arange(len(seg)), n_fill)
    frac = np.arange(n_fill.sum()) - np.repeat(np.cumsum(n_fill) - n_fill, n_fill)
    frac = frac / np.repeat(n_fill, n_fill)
    filled = points[start] + frac[:, None] * seg[start]
    return np.concatenate([filled, points[-1:]], axis=0)


def refine_poses(
    scans: Sequence[np.ndarray],
    poses: ArrayLike,
    *,
    max_correspondence_distance: float = 0.5,
    max_iterations: int = 50,
    min_matches: int = 20,
    min_overlap: float = 0.5,
    groups: ArrayLike | None = None,
) -> np.ndarray:
    """Replace consecutive odometry increments by ICP scan matching and re-chain the poses.

    For each ``i > 0``, ``scans[i]`` is aligned to ``scans[i - 1]`` starting from the odometry
    increment ``poses[i - 1] ⊖ poses[i]`` (the target densified by ``densify_scan``). A
    converged match that pairs at least ``min_overlap`` of the source points replaces the
    increment; otherwise (an empty scan, too little shared structure) the odometry increment is
    kept. The poses are re-chained from ``poses[0]``.

    ``groups`` gives the run (drive) of each scan, scikit-learn's per-sample convention (see
    ``mapping.topology.run_starts_from_groups``): where a new run begins there is no odometry
    increment from the previous scan, so that scan keeps its input pose and the next ones
    chain from it.

    Returns
    -------
    ndarray of shape (N, 3)
        Refined poses; the first pose of every run is unchanged.
    """
    poses = np.asarray(poses, dtype=float)
    out = poses.copy()
    odometry = se2_relative(poses[:-1], poses[1:])
    starts = run_starts_from_groups(groups, len(poses))
    for i in range(1, len(poses)):
        if starts[i]:
            continue
        step = odometry[i - 1]
        if len(scans[i]) >= min_matches and len(scans[i - 1]) >= min_matches:
            res = icp(
                scans[i],
                densify_scan(scans[i - 1]),
                init=step,
                max_correspondence_distance=max_correspondence_distance,
                max_iterations=max_iterations,
                min_matches=min_matches,
            )
            if res.converged and res.n_matches >= min_overlap * len(scans[i]):
                step = res.transform
        out[i] = se2_compose(out[i - 1], step)
    return out
