"""Scan-matching refinement of odometry poses (``refine_poses``).

The observation grouping of Blanco et al. assumes the poses come from a map builder (Section
IV-A); with raw odometry, heading drift smears the sensed-space overlap. ``refine_poses``
replaces each odometry increment by the ICP alignment (``icp_alignment``) of consecutive
scans, seeded with that increment, before the overlap is computed.
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np
from numpy.typing import ArrayLike

from common.geometry import se2_compose, se2_relative
from mapping.run_starts import run_starts_from_groups
from mapping.scan_matching.icp_alignment import densify_scan, icp_batch

__all__ = ["refine_poses"]


def refine_poses(
    scans: Sequence[np.ndarray],
    poses: ArrayLike,
    *,
    max_correspondence_distance: float = 0.5,
    max_iterations: int = 50,
    min_matches: int = 20,
    min_overlap: float = 0.5,
    groups: ArrayLike | None = None,
    decimation: int = 1,
) -> np.ndarray:
    """Replace consecutive odometry increments by ICP scan matching and re-chain the poses.

    For each ``i > 0``, ``scans[i]`` is aligned to ``scans[i - 1]`` starting from the odometry
    increment ``poses[i - 1] ⊖ poses[i]`` (the target densified by ``densify_scan``). A
    converged match that pairs at least ``min_overlap`` of the source points replaces the
    increment; otherwise (an empty scan, too little shared structure) the odometry increment is
    kept. The poses are re-chained from ``poses[0]``.

    ``groups`` gives the run (drive) of each scan, scikit-learn's per-sample convention (see
    ``mapping.run_starts.run_starts_from_groups``): where a new run begins there is no
    odometry increment from the previous scan, so that scan keeps its input pose and the next ones
    chain from it.

    ``decimation`` keeps every ``decimation``-th point of each source scan (the target stays
    whole), as MRPT's ICP does with ``corresponding_points_decimation``: a 2-D scan's
    neighbouring beams say nearly the same thing, and the ICP costs in proportion to the
    source points. ``min_matches`` and ``min_overlap`` then count the kept points.

    Parameters
    ----------
    scans : sequence of ndarray of shape (M_i, 2)
        Sensor-frame points of each scan.
    poses : array-like of shape (N, 3)
        Odometry poses ``(x, y, yaw)``.
    max_correspondence_distance : float, default 0.5
        ICP's initial correspondence gate in metres.
    max_iterations : int, default 50
        ICP iterations per pair at most.
    min_matches : int, default 20
        Points both scans of a pair need for a match to be tried; ICP then needs
        ``ceil(min_matches / decimation)`` correspondences.
    min_overlap : float, default 0.5
        Fraction of the kept source points a match must pair to replace the increment.
    groups : array-like of shape (N,), optional
        The run (drive) of each scan; default one run.
    decimation : int, default 1
        Keep every ``decimation``-th source point.

    Returns
    -------
    ndarray of shape (N, 3)
        Refined poses; the first pose of every run is unchanged.
    """
    integer = isinstance(decimation, int | np.integer) and not isinstance(decimation, bool)
    if not integer or decimation < 1:
        raise ValueError(f"decimation must be a positive integer, got {decimation!r}")
    poses = np.asarray(poses, dtype=float)
    steps = se2_relative(poses[:-1], poses[1:])
    starts = run_starts_from_groups(groups, len(poses))
    pairs = [
        i
        for i in range(1, len(poses))
        if not starts[i] and len(scans[i]) >= min_matches and len(scans[i - 1]) >= min_matches
    ]
    if pairs:
        sources = [np.asarray(scans[i], dtype=float).reshape(-1, 2)[::decimation] for i in pairs]
        res = icp_batch(
            sources,
            [densify_scan(scans[i - 1]) for i in pairs],
            steps[np.asarray(pairs) - 1],
            max_correspondence_distance=max_correspondence_distance,
            max_iterations=max_iterations,
            min_matches=-(-min_matches // decimation),
            workers=-1,
        )
        sizes = np.array([len(s) for s in sources])
        keep = res.converged & (res.n_matches >= min_overlap * sizes)
        steps[np.asarray(pairs)[keep] - 1] = res.transforms[keep]
    out = poses.copy()
    for i in range(1, len(poses)):
        if not starts[i]:
            out[i] = se2_compose(out[i - 1], steps[i - 1])
    return out
