"""Point-to-point ICP in SE(2): one pair (``icp``) or many at once (``icp_batch``).

Also the densified target it matches against (``densify_scan``). The refinement of odometry
poses by consecutive scan matching is ``pose_refinement.refine_poses``.
"""

from __future__ import annotations

import math
import os
from collections.abc import Sequence
from concurrent.futures import ThreadPoolExecutor
from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike
from scipy.spatial import cKDTree

__all__ = ["IcpBatchResult", "IcpResult", "densify_scan", "icp", "icp_batch"]


@dataclass(frozen=True)
class IcpResult:
    """Outcome of ``icp``.

    Parameters
    ----------
    transform : ndarray of shape (3,)
        Pose ``(x, y, yaw)`` of the source frame in the target frame.
    rmse : float
        Root-mean-square distance of the final correspondences.
    n_matches, n_iterations : int
        Correspondences at the last iteration, and iterations run.
    converged : bool
        Whether the update fell below the tolerance.

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
        Iterations run.
    converged : bool
        The update fell below ``tolerance`` with at least ``min_matches`` correspondences.
    """

    transform: np.ndarray
    rmse: float
    n_matches: int
    n_iterations: int
    converged: bool


def _kabsch_2d(p: np.ndarray, q: np.ndarray) -> tuple[float, float, float]:
    """Return the least-squares rigid motion ``(x, y, yaw)`` taking points ``p`` onto ``q``.

    In 2-D the SVD solution of the Kabsch/Umeyama problem has a closed form: the rotation
    angle is ``atan2(sum(p' x q'), sum(p' . q'))`` of the centred points, always a proper
    rotation (``_kabsch_sums``, from the points' sums).
    """
    sums = (*p.sum(axis=0), *q.sum(axis=0), *(p.T @ q).ravel())
    return tuple(float(v) for v in _kabsch_sums(len(p), *sums))


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

    Each iteration pairs every transformed source point with its nearest target point,
    drops pairs farther than ``max_correspondence_distance``, keeps those within an adaptive
    gate, and solves the rigid motion in closed form (``_kabsch_2d``). Many pairs at once:
    ``icp_batch``, which this calls with one pair.

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
        The transform, its residual and matches, and whether it converged.
    """
    init = np.zeros(3) if init is None else np.asarray(init, dtype=float).reshape(3)
    return icp_batch(
        [source],
        [target],
        init[None, :],
        max_correspondence_distance=max_correspondence_distance,
        min_correspondence_distance=min_correspondence_distance,
        max_iterations=max_iterations,
        tolerance=tolerance,
        min_matches=min_matches,
        target_tree=target_tree,
    )[0]


# Candidates remembered per point between iterations (see ``icp_batch``): 6 cut the KD-tree
# queries of the shared logs ~10x; more cost more to scan than they save.
_CACHE_K = 6
# Fewest pairs worth a thread of their own.
_MIN_CHUNK = 32


@dataclass(frozen=True)
class IcpBatchResult:
    """Outcome of ``icp_batch``, one row per pair (fields as in ``IcpResult``).

    Parameters
    ----------
    transforms : ndarray of shape (P, 3)
        Pose of each source frame in its target frame.
    rmse : ndarray of shape (P,)
        Root-mean-square distance of each pair's final correspondences.
    n_matches, n_iterations : ndarray of int, shape (P,)
        Correspondences at the last iteration, and iterations run.
    converged : ndarray of bool, shape (P,)
        Whether each pair converged.
    """

    transforms: np.ndarray
    rmse: np.ndarray
    n_matches: np.ndarray
    n_iterations: np.ndarray
    converged: np.ndarray

    def __getitem__(self, i: int) -> IcpResult:
        """Return pair ``i``'s outcome as an ``IcpResult``."""
        return IcpResult(
            self.transforms[i].copy(),
            float(self.rmse[i]),
            int(self.n_matches[i]),
            int(self.n_iterations[i]),
            bool(self.converged[i]),
        )


def icp_batch(
    sources: Sequence[ArrayLike],
    targets: Sequence[ArrayLike],
    inits: ArrayLike,
    *,
    max_correspondence_distance: float = 0.5,
    min_correspondence_distance: float = 0.05,
    max_iterations: int = 50,
    tolerance: float = 1e-6,
    min_matches: int = 10,
    target_tree: cKDTree | None = None,
    workers: int = 1,
) -> IcpBatchResult:
    """Run ``icp`` on many independent pairs at once.

    ``sources[i]`` is aligned onto ``targets[i]`` from ``inits[i]``, each pair with exactly
    ``icp``'s iterations and result.

    Two things make it cheaper than a loop of ``icp`` while giving the same correspondences:

    * every pair advances in one set of array operations per iteration (a pair leaves the
      batch when it converges or gives up), and all targets share one KD-tree, each shifted
      along x so far that no point ever finds another pair's target;
    * each source point remembers its ``_CACHE_K`` nearest target points and the position it
      was looked up from. A point that has moved by ``delta`` since then has its nearest
      neighbour among them whenever the best of them is no farther than ``r_K - delta``
      (``r_K``: distance to the K-th; every other target point is at least that far by the
      triangle inequality), and no neighbour within the gate when both exceed it. Only the
      points for which neither holds are looked up again: late ICP iterations move points by
      millimetres, so most iterations look up few points. The result is exact, not an
      approximate nearest neighbour.

    Parameters
    ----------
    sources, targets : sequences of array-like of shape (M_i, 2), (K_i, 2)
        The P pairs of point sets.
    inits : array-like of shape (P, 3)
        Initial guess of each pair's transform.
    max_correspondence_distance, min_correspondence_distance, max_iterations, tolerance, min_matches
        As in ``icp``.
    target_tree : cKDTree, optional
        With a single pair only: a tree already built on ``targets[0]``.
    workers : int, default 1
        Threads, each iterating a share of the pairs (``-1``: one per core, for batches of at
        least ``2 * _MIN_CHUNK`` pairs).

    Returns
    -------
    IcpBatchResult
        One row per pair.
    """
    if not max_correspondence_distance > 0:
        raise ValueError(
            f"max_correspondence_distance must be positive, got {max_correspondence_distance!r}"
        )
    n_pairs = len(sources)
    if len(targets) != n_pairs:
        raise ValueError(f"targets must have one entry per source ({n_pairs}), got {len(targets)}")
    inits = np.asarray(inits, dtype=float)
    if inits.shape != (n_pairs, 3):
        raise ValueError(f"inits must have shape ({n_pairs}, 3), got {inits.shape}")
    if target_tree is not None and n_pairs != 1:
        raise ValueError("target_tree is only for a single pair")
    sources = [np.asarray(s, dtype=float).reshape(-1, 2) for s in sources]
    targets = [np.asarray(t, dtype=float).reshape(-1, 2) for t in targets]
    pose = inits.copy()
    rmse = np.full(n_pairs, np.inf)
    n_matches = np.zeros(n_pairs, dtype=int)
    n_iterations = np.zeros(n_pairs, dtype=int)
    converged = np.zeros(n_pairs, dtype=bool)
    sizes = np.array([len(s) for s in sources], dtype=int)
    pairs = np.flatnonzero(
        (sizes >= min_matches) & np.array([len(t) >= min_matches for t in targets], dtype=bool)
    )
    # numpy and the KD-tree release the GIL in their loops, so chunks of pairs iterated in
    # threads use the cores without the cost of processes; chunks are independent (each its
    # own tree), and each writes only its own rows of the results
    n_threads = min(os.cpu_count() or 1, len(pairs) // _MIN_CHUNK) if workers == -1 else workers
    chunks = [c for c in np.array_split(pairs, max(n_threads, 1)) if len(c)]

    def run(chunk: np.ndarray) -> None:
        _iterate(
            [sources[i] for i in chunk],
            [targets[i] for i in chunk],
            pose,
            chunk,
            (rmse, n_matches, n_iterations, converged),
            target_tree,
            max_correspondence_distance,
            min_correspondence_distance,
            max_iterations,
            tolerance,
            min_matches,
        )

    if len(chunks) > 1:
        with ThreadPoolExecutor(len(chunks)) as pool:
            list(pool.map(run, chunks))
    elif chunks:
        run(chunks[0])
    return IcpBatchResult(pose, rmse, n_matches, n_iterations, converged)


def _iterate(
    sources,
    targets,
    pose,
    pairs,
    out,
    tree,
    max_distance,
    min_distance,
    max_iterations,
    tolerance,
    min_matches,
) -> None:
    """Run the iterations of ``icp_batch`` over the pairs with enough points.

    Batch rows are ``0..len(pairs)-1``; ``pairs`` are their indices in the result arrays
    ``pose`` and ``out = (rmse, n_matches, n_iterations, converged)``, written in place. The
    working arrays hold one entry per point of the rows still iterating and shrink as rows
    leave.
    """
    rmse, n_matches, n_iterations, converged = out
    reach = max(float(np.abs(s).max()) for s in sources) + float(np.abs(pose[pairs, :2]).max())
    reach += max(float(np.abs(t).max()) for t in targets) + 2.0 * max_distance + 1.0
    shift = 2.0 * reach * np.arange(len(pairs))  # row k's target lies at x + shift[k]
    stacked = np.concatenate([t + (s, 0.0) for t, s in zip(targets, shift, strict=True)])
    if tree is None:
        # unbalanced, uncompacted: ~40 % quicker to build, the same neighbours
        tree = cKDTree(stacked, balanced_tree=False, compact_nodes=False)
    elif tree.n != len(stacked):
        raise ValueError(f"target_tree holds {tree.n} points, target {len(stacked)}")
    # the tree answers index tree.n for "no neighbour": a point at infinity
    stacked = np.concatenate([stacked, [[1e30, 1e30]]])
    sizes = np.array([len(s) for s in sources])
    row = np.repeat(np.arange(len(pairs)), sizes)  # batch row of each working point
    col = np.arange(row.size) - np.repeat(np.cumsum(sizes) - sizes, sizes)
    src = np.concatenate(sources)
    n_pts, reach = len(src), 1.5 * max_distance
    # remembered neighbours (in the row's own frame), where they were looked up from, and
    # the distance within which they are all the target points there are
    cand_x = np.full((n_pts, _CACHE_K), 1e30)
    cand_y = np.full((n_pts, _CACHE_K), 1e30)
    from_x, from_y = np.full(n_pts, np.nan), np.full(n_pts, np.nan)
    radius = np.full(n_pts, -np.inf)
    live = np.arange(len(pairs))  # batch rows still iterating, in working-array order
    width = int(sizes.max())
    x, y, yaw = (pose[pairs, k].copy() for k in range(3))
    for it in range(1, max_iterations + 1):
        # per working point: its row's position in ``live`` and where the row's points start
        counts = np.bincount(row, minlength=len(pairs))[live]
        starts = np.cumsum(counts) - counts
        at_row = np.repeat(np.arange(len(live)), counts)
        c, s = np.cos(yaw[live]), np.sin(yaw[live])
        c, s, tx, ty = c[at_row], s[at_row], x[live][at_row], y[live][at_row]
        mx = c * src[:, 0] - s * src[:, 1] + tx
        my = s * src[:, 0] + c * src[:, 1] + ty
        d2 = np.square(cand_x - mx[:, None])
        d2 += np.square(cand_y - my[:, None])
        best = d2.argmin(axis=1)
        at = np.arange(len(mx))
        dist = np.sqrt(d2[at, best])
        room = radius - np.hypot(mx - from_x, my - from_y)
        stale = ~((dist <= room) | ((dist > max_distance) & (room > max_distance)))
        if stale.any():
            qx, qy, qs = mx[stale], my[stale], shift[row[stale]]
            dq, iq = tree.query(
                np.stack([qx + qs, qy], axis=1), k=_CACHE_K, distance_upper_bound=reach
            )
            dq, iq = dq.reshape(len(qx), -1), iq.reshape(len(qx), -1)
            cand_x[stale] = stacked[iq, 0] - qs[:, None]
            cand_y[stale] = stacked[iq, 1]
            from_x[stale], from_y[stale] = qx, qy
            radius[stale] = np.where(np.isfinite(dq[:, -1]), dq[:, -1], reach)
            dist[stale], best[stale] = dq[:, 0], 0
        ok = dist <= max_distance
        d = np.where(ok, dist, np.inf)
        n_ok = np.add.reduceat(ok, starts).astype(int)
        n_matches[pairs[live]] = n_ok
        n_iterations[pairs[live]] = it
        # adaptive gate from each row's median residual (inf pads sort last)
        padded = np.full((len(live), width), np.inf)
        padded[at_row, col] = d
        padded.sort(axis=1)
        half, rows = n_ok // 2, np.arange(len(live))
        upper = padded[rows, np.minimum(half, width - 1)]
        lower = padded[rows, np.maximum(half - 1, 0)]
        median = np.where(n_ok % 2 == 1, upper, 0.5 * (lower + upper))
        ok &= d <= np.maximum(3.0 * median, min_distance)[at_row]
        w = ok.astype(float)
        px, py, dd = w * mx, w * my, np.where(ok, dist, 0.0)
        qx, qy = np.where(ok, cand_x[at, best], 0.0), np.where(ok, cand_y[at, best], 0.0)
        terms = np.stack([w, px, py, qx, qy, px * qx, px * qy, py * qx, py * qy, dd * dd])
        n, *sums, sq = np.add.reduceat(terms, starts, axis=1)
        sx, sy, syaw = _kabsch_sums(n, *sums)
        few = n_ok < min_matches
        k = live[~few]
        cs, ss = np.cos(syaw[~few]), np.sin(syaw[~few])
        x[k], y[k] = sx[~few] + cs * x[k] - ss * y[k], sy[~few] + ss * x[k] + cs * y[k]
        yaw[k] = (yaw[k] + syaw[~few] + math.pi) % (2.0 * math.pi) - math.pi
        rmse[pairs[live]] = np.where(few, np.inf, np.sqrt(sq / np.maximum(n, 1.0)))
        done = ~few & (np.hypot(sx, sy) < tolerance) & (np.abs(syaw) < tolerance)
        converged[pairs[live[done]]] = True
        leaving = few | done
        if leaving.all():
            break
        if leaving.any():
            keep = ~leaving[at_row]
            live = live[~leaving]
            row, col, src, radius = row[keep], col[keep], src[keep], radius[keep]
            cand_x, cand_y, from_x, from_y = cand_x[keep], cand_y[keep], from_x[keep], from_y[keep]
    pose[pairs] = np.stack([x, y, yaw], axis=1)


def _kabsch_sums(n, spx, spy, sqx, sqy, sxx, sxy, syx, syy):
    """Run ``_kabsch_2d`` on many point sets from their sums.

    The sums are the counts ``n``, the coordinate sums of ``p`` and ``q`` and the sums of
    ``p_x q_x``, ``p_x q_y``, ``p_y q_x``, ``p_y q_y``.
    """
    n_safe = np.maximum(n, 1.0)
    pcx, pcy, qcx, qcy = spx / n_safe, spy / n_safe, sqx / n_safe, sqy / n_safe
    theta = np.arctan2(
        (sxy - n * pcx * qcy) - (syx - n * pcy * qcx), (sxx - n * pcx * qcx) + (syy - n * pcy * qcy)
    )
    c, s = np.cos(theta), np.sin(theta)
    return qcx - (c * pcx - s * pcy), qcy - (s * pcx + c * pcy), theta


def densify_scan(points: np.ndarray, spacing: float = 0.02, max_gap: float = 0.3) -> np.ndarray:
    """Fill the gaps between consecutive beam points with points every ``spacing`` metres.

    Point-to-point ICP between two sparse scans pairs points that are not the same spot (the
    beams hit the wall at different places), which biases the alignment by up to the beam
    spacing. Densifying the target along the scan polyline removes most of that bias while
    keeping the SVD solution. Gaps wider than ``max_gap`` (depth jumps, door edges) are not
    filled.

    Parameters
    ----------
    points : ndarray of shape (M, 2)
        The scan's points, in beam order.
    spacing : float, default 0.02
        Largest distance between filled points, in metres.
    max_gap : float, default 0.3
        Gaps longer than this (m) are left empty.

    Returns
    -------
    ndarray of shape (M', 2)
        The points with the gaps filled.
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
