"""The servo map's views in one metric frame, from what the robot sensed only.

Each recording's odometry has its own origin (``servo.maps.build``); the view graph joins the
recordings by scan matching. A pose graph over it (every edge a ``BetweenFactorPose2``,
optimised with GTSAM) puts every stored view in one frame, that of the first view. From the
placed scans come what a laser controller needs to start anywhere:

* a point map (the scans, densified and thinned to a grid) with a KD-tree for ICP, and a
  distance field for scoring many candidate poses at once (global localisation);
* free space: the cells the laser beams crossed, minus the cells near a return, grown by the
  robot's radius: a grid to plan shortest paths on (`GeodesicField`).

Nothing here reads the map's ``true_poses``: they are for the evaluation only.
"""

from __future__ import annotations

import gtsam
import numpy as np
from scipy import ndimage
from scipy.spatial import cKDTree

from common.geometry import se2_compose, se2_inverse, thin_to_grid, transform_points
from mapping.scan_matching import densify_scan
from scenes.regions import OccupancyGrid
from scenes.robot import RADIUS
from servo.maps import ServoMap

__all__ = ["MetricMap", "align_views"]

POINT_SPACING = 0.05  # m between the point map's points
FIELD_RESOLUTION = 0.05  # m per cell of the distance field
FREE_RESOLUTION = 0.1  # m per cell of the planning grid
FREE_RANGE = 8.0  # m of each beam marked free (no return: the whole of it)
PLAN_MARGIN = 0.12  # m beyond the robot's radius kept from any return
ODOMETRY_SIGMAS = (0.02, 0.02, 0.005)  # m, m, rad: scan-matched increment between views
LINK_SIGMAS = (0.03, 0.03, 0.01)  # a link between recordings (ICP of two views' scans)


def align_views(servo_map: ServoMap) -> np.ndarray:
    """Return every stored view's pose in the frame of view 0.

    The poses are the least squares solution over the view graph's edges (a 2-D pose graph,
    Levenberg-Marquardt). Views of recordings the graph does not join to view 0 keep their own
    recording's odometry, anchored at its first view.

    Parameters
    ----------
    servo_map : ServoMap
        The map whose views are placed.

    Returns
    -------
    ndarray of shape (n, 3)
        The views' poses (x, y, yaw) in view 0's frame.
    """
    m = servo_map
    graph = gtsam.NonlinearFactorGraph()
    initial = gtsam.Values()
    a, b = m.edges.T
    cross = m.sequence[a] != m.sequence[b]
    odo = gtsam.noiseModel.Diagonal.Sigmas(np.array(ODOMETRY_SIGMAS))
    link = gtsam.noiseModel.Diagonal.Sigmas(np.array(LINK_SIGMAS))
    for (i, j), t, c in zip(m.edges, m.edge_transforms, cross, strict=True):
        graph.add(gtsam.BetweenFactorPose2(int(i), int(j), gtsam.Pose2(*t), link if c else odo))
    prior = gtsam.noiseModel.Diagonal.Sigmas(np.array([1e-3, 1e-3, 1e-4]))
    # Initial guess: each recording's odometry, placed by the first link that reaches it.
    placed, reached = _chain_recordings(m)
    for s in np.unique(m.sequence):
        if s == m.sequence[0] or int(s) not in reached:  # a recording no link joins: its own
            first = int(np.flatnonzero(m.sequence == s)[0])
            graph.add(gtsam.PriorFactorPose2(first, gtsam.Pose2(*placed[first]), prior))
    for k, p in enumerate(placed):
        initial.insert(k, gtsam.Pose2(*p))
    result = gtsam.LevenbergMarquardtOptimizer(graph, initial).optimize()
    return np.array(
        [
            [result.atPose2(k).x(), result.atPose2(k).y(), result.atPose2(k).theta()]
            for k in range(len(m))
        ]
    )


def _chain_recordings(m: ServoMap) -> tuple[np.ndarray, set]:
    """Return each recording's odometry poses moved into view 0's frame, and those reached.

    A recording is moved through the first link that reaches it (breadth first over
    recordings); the others keep their own frame.
    """
    out = np.asarray(m.poses, np.float64).copy()
    reached, queue = {int(m.sequence[0])}, [int(m.sequence[0])]
    while queue:
        s = queue.pop(0)
        for (i, j), t in zip(m.edges, m.edge_transforms, strict=True):
            for u, v, tr in ((i, j, t), (j, i, se2_inverse(t))):
                other = int(m.sequence[v])
                if m.sequence[u] == s and other not in reached:
                    # the recording's frame in the map frame: view v placed through the link
                    frame = se2_compose(se2_compose(out[u], tr), se2_inverse(m.poses[v]))
                    mine = m.sequence == other
                    out[mine] = se2_compose(frame, m.poses[mine])
                    reached.add(other)
                    queue.append(other)
    return out, reached


class MetricMap:
    """A servo map's views placed in one frame, their scans as a point map, and free space.

    See the module docstring.

    Parameters
    ----------
    servo_map : ServoMap
        The map whose views are placed.

    Attributes
    ----------
    poses : ndarray of shape (n, 3)
        The views' poses in the map frame.
    """

    def __init__(self, servo_map: ServoMap):
        if not isinstance(servo_map, ServoMap):
            raise TypeError(f"servo_map must be a ServoMap, got {type(servo_map).__name__}")
        self.map = servo_map
        self.poses = align_views(servo_map)
        scans = [servo_map.scan_points(k) for k in range(len(servo_map))]
        placed = [
            transform_points(p, densify_scan(s, POINT_SPACING))
            for p, s in zip(self.poses, scans, strict=True)
            if len(s)
        ]
        self.points = thin_to_grid(np.concatenate(placed), POINT_SPACING)
        self.tree = cKDTree(self.points)
        self.origin = self.points.min(axis=0) - 2.0
        top = self.points.max(axis=0) + 2.0
        shape = tuple(np.ceil((top - self.origin) / FIELD_RESOLUTION).astype(int)[::-1])
        occupied = np.zeros(shape, bool)
        i, j = self._field_cells(self.points)
        occupied[i, j] = True
        # m to the nearest map point, per cell: scores many candidate poses by lookups
        self.field = (ndimage.distance_transform_edt(~occupied) * FIELD_RESOLUTION).astype(
            np.float32
        )
        self.grid = self._free_space(scans)

    def _field_cells(self, xy: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        ij = np.floor((xy - self.origin) / FIELD_RESOLUTION).astype(np.int64)
        return ij[..., 1], ij[..., 0]

    def distance(self, xy: np.ndarray) -> np.ndarray:
        """Return the distance from each point to the nearest map point.

        Parameters
        ----------
        xy : ndarray of shape (..., 2)
            Points in the map frame, m.

        Returns
        -------
        ndarray of shape (...), float32
            Distance to the nearest map point, m (off the field: 10).
        """
        i, j = self._field_cells(np.asarray(xy, np.float64))
        h, w = self.field.shape
        inside = (i >= 0) & (i < h) & (j >= 0) & (j < w)
        out = np.full(np.shape(i), 10.0, np.float32)
        out[inside] = self.field[i[inside], j[inside]]
        return out

    def _free_space(self, scans: list) -> OccupancyGrid:
        """Return the free space: where the robot may plan to drive.

        That is the cells crossed by the views' beams (up to ``FREE_RANGE``), kept
        ``RADIUS + PLAN_MARGIN`` away from every map point.
        """
        m = self.map
        h = int(np.ceil((self.field.shape[0] * FIELD_RESOLUTION) / FREE_RESOLUTION))
        w = int(np.ceil((self.field.shape[1] * FIELD_RESOLUTION) / FREE_RESOLUTION))
        seen = np.zeros((h, w), bool)
        beams = np.arange(0, len(m.angles), 2)
        steps = np.arange(0.0, FREE_RANGE, FREE_RESOLUTION / 2)
        for pose, ranges in zip(self.poses, m.scans, strict=True):
            r = np.nan_to_num(
                np.minimum(ranges[beams], FREE_RANGE), nan=FREE_RANGE, posinf=FREE_RANGE
            )
            a = pose[2] + m.angles[beams]
            d = steps[None, :]
            ok = d < r[:, None] - FREE_RESOLUTION
            x = pose[0] + np.cos(a)[:, None] * d
            y = pose[1] + np.sin(a)[:, None] * d
            jj = np.floor((x[ok] - self.origin[0]) / FREE_RESOLUTION).astype(np.int64)
            ii = np.floor((y[ok] - self.origin[1]) / FREE_RESOLUTION).astype(np.int64)
            keep = (ii >= 0) & (ii < h) & (jj >= 0) & (jj < w)
            seen[ii[keep], jj[keep]] = True
        blocked = np.zeros((h, w), bool)
        ij = np.floor((self.points - self.origin) / FREE_RESOLUTION).astype(np.int64)
        blocked[ij[:, 1], ij[:, 0]] = True
        clearance = ndimage.distance_transform_edt(~blocked) * FREE_RESOLUTION
        free = seen & (clearance > RADIUS + PLAN_MARGIN)
        return OccupancyGrid(free, (float(self.origin[0]), float(self.origin[1])), FREE_RESOLUTION)

    def fit(self, points: np.ndarray, poses: np.ndarray, tol: float) -> np.ndarray:
        """Return the share of ``points`` within ``tol`` of the map, for each of ``poses``.

        This is the score of candidate poses in global localisation.

        Parameters
        ----------
        points : ndarray of shape (M, 2)
            Scan points in the robot frame, m.
        poses : ndarray of shape (P, 3) or (3,)
            Candidate poses in the map frame.
        tol : float
            Largest distance of a point from the map that counts as fitting, m.

        Returns
        -------
        ndarray of shape (P,)
            The share of points that fit, per pose.
        """
        poses = np.atleast_2d(poses)
        c, s = np.cos(poses[:, 2]), np.sin(poses[:, 2])
        x = poses[:, None, 0] + c[:, None] * points[None, :, 0] - s[:, None] * points[None, :, 1]
        y = poses[:, None, 1] + s[:, None] * points[None, :, 0] + c[:, None] * points[None, :, 1]
        return (self.distance(np.stack([x, y], -1)) <= tol).mean(axis=1)
