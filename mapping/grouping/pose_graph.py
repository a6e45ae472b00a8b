"""Loop closure for the grouping's poses: a 2-D pose graph optimised with GTSAM.

The grouping assumes globally consistent poses (Blanco et al., Section IV-A: poses from a map
builder). Sequential scan matching (``mapping.scan_matching.refine_poses``) only slows drift; a
route that comes back to a place needs loop closure. ``close_loops`` builds the standard pose graph:

* one ``gtsam.BetweenFactorPose2`` per consecutive pair of scans of a run: the ICP alignment
  of the two scans seeded with the odometry increment, or the odometry increment itself where
  ICP fails (looser noise);
* loop-closure candidates: scan pairs far apart in time whose chained poses lie within
  ``loop_radius`` (proximity), each verified by ICP (converged, most points matched, small
  residual) and added as a factor under a robust kernel (Cauchy by default), so a wrong
  match that passed verification is down-weighted rather than bending the map;
* a prior on the first pose of every run (a run's odometry starts where the robot is);

then optimises it with Levenberg-Marquardt.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

import gtsam
import numpy as np
from numpy.typing import ArrayLike
from scipy.spatial import cKDTree

from common.geometry import se2_compose, se2_relative
from mapping.run_starts import run_starts_from_groups
from mapping.scan_matching import densify_scan, icp_batch

__all__ = ["LoopClosureResult", "absolute_trajectory_error", "close_loops"]

ROBUST = {"cauchy": gtsam.noiseModel.mEstimator.Cauchy, "huber": gtsam.noiseModel.mEstimator.Huber}


@dataclass(frozen=True)
class LoopClosureResult:
    """Outcome of ``close_loops``.

    Parameters
    ----------
    poses, chained : ndarray of shape (N, 3)
        Optimised poses, and the poses before loop closure.
    loops : ndarray of shape (L, 2)
        Accepted loop closures.
    candidates : int
        Pairs checked by ICP.
    error_before, error_after : float
        The factor graph's error before and after the optimisation.

    Attributes
    ----------
    poses : ndarray of shape (N, 3)
        Optimised poses.
    chained : ndarray of shape (N, 3)
        The poses before loop closure: the consecutive factors chained (odometry + ICP).
    loops : ndarray of shape (L, 2)
        Scan pairs ``(i, j)``, ``i > j``, accepted as loop closures.
    candidates : int
        Pairs proposed by proximity and checked by ICP.
    error_before, error_after : float
        The factor graph's error at the chained and at the optimised poses.
    """

    poses: np.ndarray
    chained: np.ndarray
    loops: np.ndarray
    candidates: int
    error_before: float
    error_after: float


def _noise(sigmas: Sequence[float], robust: str | None = None, k: float = 1.0):
    base = gtsam.noiseModel.Diagonal.Sigmas(np.asarray(sigmas, dtype=float))
    if robust is None:
        return base
    return gtsam.noiseModel.Robust.Create(ROBUST[robust].Create(k), base)


def close_loops(
    scans: Sequence[np.ndarray],
    odometry: ArrayLike,
    *,
    groups: ArrayLike | None = None,
    loop_radius: float = 3.0,
    min_separation: int = 30,
    stride: int = 3,
    icp_max_distance: float = 1.0,
    min_overlap: float = 0.6,
    max_rmse: float = 0.1,
    robust: str = "cauchy",
    odometry_sigmas: Sequence[float] = (0.1, 0.1, 0.05),
    icp_sigmas: Sequence[float] = (0.02, 0.02, 0.005),
    loop_sigmas: Sequence[float] = (0.05, 0.05, 0.01),
) -> LoopClosureResult:
    """Correct ``odometry`` poses with a GTSAM pose graph closed by verified scan matches.

    Parameters
    ----------
    scans : sequence of (M_i, 2) arrays
        Points of each scan in its sensor frame.
    odometry : array-like of shape (N, 3)
        Odometry poses; each run's first pose anchors the run (prior factor).
    groups : array-like of shape (N,), optional
        The run (drive) of each scan, as in ``ObservationGraphPartitioner.fit``.
    loop_radius : float, default 3.0
        Candidate pairs lie within this distance (m) on the chained poses; it must cover the
        drift accumulated between the two visits.
    min_separation : int, default 30
        Scans of one run closer than this in time are neighbours, not a loop.
    stride : int, default 3
        Every ``stride``-th scan proposes candidates (its nearest one per earlier visit).
    icp_max_distance, min_overlap, max_rmse
        Verification: ICP from the chained relative pose with this initial correspondence
        gate (m) must converge, pair ``min_overlap`` of the scan's points and leave an RMSE
        below ``max_rmse`` (m).
    robust : {"cauchy", "huber"}
        M-estimator of the loop-closure factors (``gtsam.noiseModel.mEstimator``).
    odometry_sigmas, icp_sigmas, loop_sigmas
        Standard deviations ``(x, y, yaw)`` of odometry, consecutive-ICP and loop factors.

    Returns
    -------
    LoopClosureResult
        The optimised and chained poses, the accepted loops, the candidates checked and the
        graph's error before and after.
    """
    odometry = np.asarray(odometry, dtype=float)
    n = len(odometry)
    if odometry.ndim != 2 or odometry.shape[1] != 3 or len(scans) != n:
        raise ValueError(f"odometry must have shape (len(scans), 3), got {odometry.shape}")
    if not np.all(np.isfinite(odometry)):
        raise ValueError("odometry contains NaN or inf")
    if robust not in ROBUST:
        raise ValueError(f"robust must be one of {sorted(ROBUST)}, got {robust!r}")
    starts = run_starts_from_groups(groups, n)
    run = np.cumsum(starts) - 1 if n else np.zeros(0, int)
    graph = gtsam.NonlinearFactorGraph()
    chained = odometry.copy()
    odo_noise, icp_noise = _noise(odometry_sigmas), _noise(icp_sigmas)
    prior = _noise((1e-3, 1e-3, 1e-4))
    steps = se2_relative(odometry[:-1], odometry[1:])
    follows = np.flatnonzero(~starts[1:]) + 1  # scans with a predecessor in their run
    seq = icp_batch(
        [scans[i] for i in follows],
        [densify_scan(scans[i - 1]) for i in follows],
        steps[follows - 1],
        max_correspondence_distance=0.5,
        workers=-1,
    )
    matched = np.zeros(n, dtype=bool)
    sizes = np.array([len(scans[i]) for i in follows], dtype=int)
    ok = seq.converged & (seq.n_matches >= 0.5 * sizes)
    matched[follows[ok]] = True
    steps[follows[ok] - 1] = seq.transforms[ok]
    for i in range(n):
        if starts[i]:
            graph.add(gtsam.PriorFactorPose2(i, gtsam.Pose2(*odometry[i]), prior))
            continue
        noise = icp_noise if matched[i] else odo_noise
        graph.add(gtsam.BetweenFactorPose2(i - 1, i, gtsam.Pose2(*steps[i - 1]), noise))
        chained[i] = se2_compose(chained[i - 1], steps[i - 1])

    tree = cKDTree(chained[:, :2])
    proposed = []
    for i in range(0, n, stride):
        near = np.asarray(tree.query_ball_point(chained[i, :2], loop_radius), dtype=int)
        near = near[(near < i) & ((run[near] != run[i]) | (i - near >= min_separation))]
        if not len(near):
            continue
        # one candidate per earlier visit: visits are separated by gaps in the scan index
        near = np.sort(near)
        visits = np.split(near, np.flatnonzero(np.diff(near) > 1) + 1)
        for visit in visits:
            d = np.hypot(*(chained[visit, :2] - chained[i, :2]).T)
            proposed.append((i, int(visit[np.argmin(d)])))
    candidates, loops = len(proposed), []
    if proposed:
        pair = np.asarray(proposed, dtype=int)
        res = icp_batch(
            [scans[i] for i in pair[:, 0]],
            [densify_scan(scans[j]) for j in pair[:, 1]],
            se2_relative(chained[pair[:, 1]], chained[pair[:, 0]]),
            max_correspondence_distance=icp_max_distance,
            workers=-1,
        )
        sizes = np.array([len(scans[i]) for i in pair[:, 0]], dtype=int)
        good = res.converged & (res.n_matches >= min_overlap * sizes) & (res.rmse <= max_rmse)
        loop_noise = _noise(loop_sigmas, robust)
        for k in np.flatnonzero(good):
            i, j = (int(v) for v in pair[k])
            graph.add(gtsam.BetweenFactorPose2(j, i, gtsam.Pose2(*res.transforms[k]), loop_noise))
            loops.append((i, j))
    initial = gtsam.Values()
    for i in range(n):
        initial.insert(i, gtsam.Pose2(*chained[i]))
    params = gtsam.LevenbergMarquardtParams()
    params.setMaxIterations(100)
    result = gtsam.LevenbergMarquardtOptimizer(graph, initial, params).optimize()
    poses = np.array([[p.x(), p.y(), p.theta()] for p in (result.atPose2(i) for i in range(n))])
    return LoopClosureResult(
        poses=poses.reshape(n, 3),
        chained=chained,
        loops=np.asarray(loops, dtype=int).reshape(-1, 2),
        candidates=candidates,
        error_before=float(graph.error(initial)),
        error_after=float(graph.error(result)),
    )


def absolute_trajectory_error(estimate: ArrayLike, truth: ArrayLike) -> dict:
    """Return the position and heading error of ``estimate`` against ``truth``.

    Both are in the common frame (anchored at the same start pose), so no alignment is fitted.

    Parameters
    ----------
    estimate, truth : array-like of shape (N, 3)
        Estimated and true poses ``(x, y, yaw)``.

    Returns
    -------
    dict
        ``rmse_m``, ``mean_m`` and ``max_m``: RMSE, mean and max of the position error in
        metres; ``heading_rmse_deg``: the RMSE of the heading in degrees.
    """
    estimate, truth = np.asarray(estimate, dtype=float), np.asarray(truth, dtype=float)
    d = np.hypot(*(estimate[:, :2] - truth[:, :2]).T)
    dyaw = np.angle(np.exp(1j * (estimate[:, 2] - truth[:, 2])))
    return {
        "rmse_m": float(np.sqrt(np.mean(d**2))),
        "mean_m": float(d.mean()),
        "max_m": float(d.max()),
        "heading_rmse_deg": float(np.degrees(np.sqrt(np.mean(dyaw**2)))),
    }
