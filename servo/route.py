"""The route graph of a servo map, its shortest routes and their waypoints.

Stored views are joined along recordings and across the links where recordings meet, weighted
by the scan-matched odometry between them (no ground truth). Routes are shortest paths in it;
waypoints are route views about ``spacing`` apart.
"""

from __future__ import annotations

import itertools

import numpy as np
from scipy import sparse
from scipy.sparse.csgraph import dijkstra

from common.geometry import se2_compose, se2_relative
from servo.maps import MapError, ServoMap

LINK_PENALTY = 1.0  # m added to a link between recordings: stay on one recording if possible


class RouteGraph:
    """Shortest routes over the view graph of ``servo_map`` (its ``edges``).

    Parameters
    ----------
    servo_map : ServoMap
        The map.
    link_penalty : float, default LINK_PENALTY
        Metres added to a link between recordings.
    """

    def __init__(self, servo_map: ServoMap, link_penalty: float = LINK_PENALTY):
        if not isinstance(servo_map, ServoMap):
            raise TypeError(f"servo_map must be a ServoMap, got {type(servo_map).__name__}")
        m = self.map = servo_map
        a, b = m.edges.T
        cross = m.sequence[a] != m.sequence[b]
        w = np.hypot(*m.edge_transforms[:, :2].T) + 0.05 + float(link_penalty) * cross
        n = len(m)
        self.graph = sparse.csr_matrix((np.r_[w, w], (np.r_[a, b], np.r_[b, a])), shape=(n, n))
        self.transform: dict[tuple[int, int], np.ndarray] = {}
        for (i, j), t in zip(m.edges, m.edge_transforms, strict=True):
            self.transform[(int(i), int(j))] = t
            self.transform[(int(j), int(i))] = se2_relative(t, np.zeros(3))

    def route(self, start: int, target: int) -> list[int]:
        """Return the stored views from ``start`` to ``target`` along the shortest path.

        Both ends are included; ``MapError`` where ``target`` is unreachable.

        Parameters
        ----------
        start, target : int
            Stored-view indices.

        Returns
        -------
        list of int
            The route's views.
        """
        start = self.map.check_view(start, "start")
        target = self.map.check_view(target, "target")
        _, pred = dijkstra(self.graph, indices=start, return_predecessors=True)
        route = [target]
        while route[-1] != start:
            p = int(pred[route[-1]])
            if p < 0:
                raise MapError(f"stored view {target} is unreachable from view {start}")
            route.append(p)
        return route[::-1]

    def frames(self, route: list[int]) -> np.ndarray:
        """Return each route view's pose in the first one's frame (edges chained).

        Parameters
        ----------
        route : list of int
            Consecutive views joined by edges (`route`).

        Returns
        -------
        ndarray of shape (len(route), 3)
            The poses (x, y, yaw).
        """
        out = [np.zeros(3)]
        for i, j in itertools.pairwise(route):
            out.append(se2_compose(out[-1], self.transform[(i, j)]))
        return np.array(out)

    def waypoints(self, route: list[int], spacing: float) -> tuple[list[int], np.ndarray]:
        """Return route views about ``spacing`` m apart, and each one's direction of travel.

        The last waypoint is the target. The direction is +1 when the next waypoint lies ahead
        of the view's heading (drive forward facing it), -1 when behind (the recording is
        driven backwards: reverse, still facing the way the view looks).

        Parameters
        ----------
        route : list of int
            The route's views (`route`).
        spacing : float
            Metres between waypoints along the route.

        Returns
        -------
        waypoints : list of int
            The waypoint views.
        directions : ndarray of shape (len(waypoints),)
            +1 or -1 per waypoint.
        """
        if not spacing > 0:
            raise ValueError(f"spacing must be > 0 m, got {spacing}")
        f = self.frames(route)
        arc = np.r_[0.0, np.cumsum(np.hypot(*np.diff(f[:, :2], axis=0).T))]
        keep, last = [], -np.inf
        for k in range(1, len(route)):
            if arc[k] - last >= spacing or k == len(route) - 1:
                keep.append(k)
                last = arc[k]
        if not keep:  # already at the target view
            keep = [0]
        direction = []
        prev = 0
        for k in keep:
            # the waypoint seen from the previous one, in the waypoint's own frame
            rel = se2_relative(f[k], f[prev]) if k != prev else np.zeros(3)
            direction.append(-1 if rel[0] > 0 else 1)
            prev = k
        return [route[k] for k in keep], np.array(direction)

    def manifold_route(self, route: list[int]) -> list[int]:
        """Return the clusters the route crosses, in order (the manifold graph's path).

        Parameters
        ----------
        route : list of int
            The route's views.

        Returns
        -------
        list of int
            The clusters, consecutive repeats merged.
        """
        c = self.map.clusters[route]
        return [int(v) for v in c[np.r_[True, c[1:] != c[:-1]]]]


class RoutePath:
    """A route's views as a polyline in the route frame (the first view's), by arc length.

    The robot's progress along the route is the arc length of the nearest point of the
    polyline.

    Parameters
    ----------
    frames : ndarray of shape (n, 3)
        Each route view's pose in the route frame (`RouteGraph.frames`), n >= 1.
    """

    def __init__(self, frames: np.ndarray):
        frames = np.asarray(frames, np.float64)
        if frames.ndim != 2 or frames.shape[1] != 3 or len(frames) == 0:
            raise ValueError(f"frames must be (n, 3) poses, n >= 1, got shape {frames.shape}")
        if not np.all(np.isfinite(frames)):
            raise ValueError("frames must be finite")
        self.frames = frames
        self.arc = np.r_[0.0, np.cumsum(np.hypot(*np.diff(frames[:, :2], axis=0).T))]

    @property
    def length(self) -> float:
        """The route's length, m."""
        return float(self.arc[-1])

    def point(self, s: float) -> np.ndarray:
        """Return the (x, y) at arc length ``s`` (clipped to the route).

        Parameters
        ----------
        s : float
            Arc length, m.

        Returns
        -------
        ndarray of shape (2,)
            The point in the route frame.
        """
        s = float(np.clip(s, 0.0, self.length))
        return np.array([np.interp(s, self.arc, self.frames[:, k]) for k in (0, 1)])

    def project(self, xy, near: float, window: float) -> float:
        """Return the arc length of the point of the polyline nearest ``xy``, near ``near``.

        Only the segments within ``window`` m of arc ``near`` are searched: a window, so that
        where the route passes a place twice (a junction driven out and back) progress does not
        jump to the other pass.

        Parameters
        ----------
        xy : array_like of shape (2,)
            The point, in the route frame.
        near : float
            Arc length the search is centred on, m.
        window : float
            Arc length either side of ``near`` searched, m.

        Returns
        -------
        float
            The arc length, m (``near`` clipped to the route where no segment is in the window).
        """
        xy = np.asarray(xy, np.float64)
        if len(self.frames) == 1:
            return 0.0
        a, b = self.frames[:-1, :2], self.frames[1:, :2]
        ab = b - a
        t = np.clip(np.einsum("ij,ij->i", xy - a, ab) / np.maximum((ab * ab).sum(1), 1e-12), 0, 1)
        d = np.hypot(*(a + t[:, None] * ab - xy).T)
        s = self.arc[:-1] + t * np.diff(self.arc)
        d[np.abs(s - near) > window] = np.inf
        k = int(np.argmin(d))
        return float(s[k]) if np.isfinite(d[k]) else float(np.clip(near, 0.0, self.length))

    def within(self, s: float, behind: float, ahead: float) -> np.ndarray:
        """Return the indices of the route views whose arc length lies in [s - behind, s + ahead].

        Parameters
        ----------
        s : float
            Arc length, m.
        behind, ahead : float
            Metres of arc before and after ``s``.

        Returns
        -------
        ndarray of int
            The indices into the route.
        """
        return np.flatnonzero((self.arc >= s - behind) & (self.arc <= s + ahead))
