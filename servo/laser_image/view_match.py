"""Scan matching of the current laser scan against a servo map's stored views.

`ViewMatcher` runs ICP (``mapping.scan_matching``) of the current scan on one stored view's scan
(or on a given ``(tree, points)`` map) and scores a match by its overlap both ways, which is
what tells places along a uniform corridor apart: ``ManifoldServo``'s arrival check.
"""

from __future__ import annotations

import numpy as np
from scipy.spatial import cKDTree

from common.geometry import transform_points
from mapping.scan_matching import densify_scan, icp
from servo.maps import ServoMap

__all__ = ["ViewMatcher"]


class ViewMatcher:
    """ICP of scans on the stored views of ``servo_map`` (each view's tree built once).

    Parameters
    ----------
    servo_map : ServoMap
        The map whose stored views are matched.
    """

    def __init__(self, servo_map: ServoMap):
        self.map = servo_map
        self._trees: dict[int, tuple[cKDTree, np.ndarray]] = {}

    def tree(self, view: int) -> tuple[cKDTree, np.ndarray]:
        """Return the KD-tree and points of stored view ``view``'s densified scan.

        Parameters
        ----------
        view : int
            Index of a stored view.

        Returns
        -------
        tree : cKDTree
            The KD-tree of the points.
        points : ndarray of shape (M, 2)
            The densified scan in the view's frame, m.
        """
        if view not in self._trees:
            dense = densify_scan(self.map.scan_points(view))
            self._trees[view] = (cKDTree(dense), dense)
        return self._trees[view]

    def match(self, points: np.ndarray, view: int, init, iterations: int = 20, target=None):
        """Run ICP of ``points`` on view ``view``'s scan (or on a given local map).

        Parameters
        ----------
        points : ndarray of shape (M, 2)
            The current scan's points, m.
        view : int
            Index of a stored view.
        init : array_like of shape (3,)
            The initial pose of ``points`` in the view's (or the target's) frame.
        iterations : int, default 20
            Largest number of ICP iterations.
        target : tuple of (cKDTree, ndarray) or None, default None
            A ``(tree, points)`` local map to match on instead of the view's scan.

        Returns
        -------
        result : IcpResult
            The ICP result (``mapping.scan_matching.icp``).
        frac : float
            The share of ``points`` matched.
        """
        tree, dense = self.tree(view) if target is None else target
        res = icp(points, dense, init=init, target_tree=tree, max_iterations=iterations)
        frac = res.n_matches / max(len(points), 1)
        return res, frac

    def score(self, points: np.ndarray, view: int, init) -> tuple[float, np.ndarray]:
        """Match the current scan on a stored view's by ICP, scored by the overlap both ways.

        The score adds the share of current points matched and of the view's points matched
        (less twice the residual, capped at 0.5 m). The second term is what tells places along
        a uniform corridor apart (the end wall must match too).

        Parameters
        ----------
        points : ndarray of shape (M, 2)
            The current scan's points, m.
        view : int
            Index of a stored view.
        init : array_like of shape (3,)
            The initial pose of ``points`` in the view's frame.

        Returns
        -------
        score : float
            The score (-inf when ICP fails).
        transform : ndarray of shape (3,)
            The pose ICP found.
        """
        res, frac = self.match(points, view, init, iterations=30)
        if not np.isfinite(res.rmse):
            return -np.inf, res.transform
        view_points = self.map.scan_points(view)[::3]
        moved = transform_points(res.transform, points)
        d, _ = cKDTree(densify_scan(moved)).query(view_points, distance_upper_bound=0.15)
        back = float(np.mean(np.isfinite(d))) if len(view_points) else 0.0
        return frac + back - 2.0 * min(res.rmse, 0.5), res.transform
