"""Where the robot is on its route, from odometry and images only (no laser, no truth).

`RouteBelief` holds the robot's pose in the route's frame (the first route view's,
chained through the view graph's sensed transforms, `servo.route.RouteGraph.frames`):
odometry carries it (`RouteBelief.predict`) and an image fix against one route view
corrects it (`RouteBelief.fix`): the best horizontal shift of the image against the
view gives the heading (the view's heading minus the shift's angle), and that the image
matches the view best among its neighbours puts the robot about at the view along its line
of sight. Nothing here depends on a global frame.
"""

from __future__ import annotations

import numpy as np

from common.geometry import se2_compose, se2_relative, wrap_angle
from servo.route import RoutePath


class RouteBelief:
    """The robot's pose in the route frame and its progress (arc length) along the route.

    Parameters
    ----------
    path : RoutePath
        The route, in its frame.
    pose : array_like of shape (3,)
        The pose (x, y, yaw) in the route frame at the start (m, m, rad).
    window : float, default 2.0
        The arc (m) either side of the current progress within which progress may move at one
        step (where the route passes a place twice it stays on the right pass).
    """

    def __init__(self, path: RoutePath, pose, window: float = 2.0):
        if not isinstance(path, RoutePath):
            raise TypeError(f"path must be a RoutePath, got {type(path).__name__}")
        pose = np.asarray(pose, np.float64)
        if pose.shape != (3,) or not np.all(np.isfinite(pose)):
            raise ValueError(f"pose must be a finite (x, y, yaw), got {pose!r}")
        if not window > 0:
            raise ValueError(f"window must be > 0 m, got {window}")
        self.path, self.window = path, float(window)
        self.pose = pose.copy()
        self.s = path.project(pose[:2], 0.0, np.inf)

    def predict(self, odometry_step) -> None:
        """Carry the pose by an odometry increment (x, y, yaw in the robot frame).

        Parameters
        ----------
        odometry_step : array_like of shape (3,)
            The increment (x, y, yaw) in the robot frame (m, m, rad).
        """
        self.pose = se2_compose(self.pose, np.asarray(odometry_step, np.float64))
        self.s = self.path.project(self.pose[:2], self.s, self.window)

    def facing(self, views: np.ndarray, tolerance: float) -> np.ndarray:
        """Keep the route views that look the way the robot faces.

        Returns those of ``views`` (indices into the route) that look within ``tolerance`` rad
        of the robot's heading: only their images can match the camera's.

        Parameters
        ----------
        views : numpy.ndarray
            Route view indices.
        tolerance : float
            The largest difference from the robot's heading, rad.

        Returns
        -------
        numpy.ndarray
            Those of ``views`` that look the robot's way, in their order.
        """
        views = np.asarray(views, np.intp)
        off = wrap_angle(self.path.frames[views, 2] - self.pose[2])
        return views[np.abs(off) < tolerance]

    def fix(self, view: int, yaw: float, heading_gain: float, along_gain: float) -> float:
        """Correct the pose by an image fix against route view ``view``.

        ``view`` indexes the route; its best shift says turning ``yaw`` rad lines the image up
        with it. The heading is corrected toward ``frame yaw - yaw``, the position along the
        view's line of sight toward the view. Returns the along-sight offset (m) the fix found
        before correcting.

        Parameters
        ----------
        view : int
            The route view's index.
        yaw : float
            The turn (rad) that lines the image up with the view (its best shift).
        heading_gain : float
            The share of the heading error corrected.
        along_gain : float
            The share of the along-sight offset corrected.

        Returns
        -------
        float
            The belief's offset ahead of the view along its sight before the fix, m.
        """
        frame = self.path.frames[int(view)]
        err = wrap_angle(frame[2] - yaw - self.pose[2])
        self.pose[2] = wrap_angle(self.pose[2] + heading_gain * err)
        ahead = float(se2_relative(frame, self.pose)[0])  # robot ahead of the view (m)
        u = np.array([np.cos(frame[2]), np.sin(frame[2])])
        self.pose[:2] -= along_gain * ahead * u
        self.s = self.path.project(self.pose[:2], self.s, self.window)
        return ahead

    def fix_reversing(
        self, view: int, yaw: float, parallax: float, heading_gain: float, cross_gain: float
    ) -> float:
        """Fix the belief of a robot *reversing* along the route by an image.

        The robot faces the way route view ``view`` looks; returns the innovation (rad).

        The best shift measures the heading error plus ``parallax`` times the offset across
        the view's line of sight (left positive): z = theta + c y. Driving backwards,
        dy/ds = -theta per metre reversed, and the forward fix (heading toward z) makes the
        belief's cross-track error grow: the error system [e_theta, e_y]' = [[-g1, -g1 c],
        [-1 - g2, -g2 c]] has determinant -g1 c < 0 for any heading gain g1 > 0 (a saddle).
        With the heading corrected *against* the innovation (g1 < 0) and the offset across
        corrected with it (g2 > |g1| / c) the determinant |g1| c and the trace -(g2 c - |g1|)
        make it stable: the offset becomes observable through the motion. Here
        ``heading_gain`` is |g1| and ``cross_gain`` g2 per step (per metre times the step's
        length). Nothing is fixed along the route: reversing, the robot moves away from the
        views it sees, and at a junction the nearest of them stays behind it.

        Parameters
        ----------
        view : int
            The route view's index.
        yaw : float
            The turn (rad) that lines the image up with the view (its best shift).
        parallax : float
            The image shift per metre across the view's sight, c (rad/m).
        heading_gain : float
            |g1| for this step.
        cross_gain : float
            g2 for this step (m per rad of innovation).

        Returns
        -------
        float
            The innovation r, rad.
        """
        frame = self.path.frames[int(view)]
        rel = se2_relative(frame, self.pose)  # belief in the view's frame
        r = wrap_angle(frame[2] - yaw - self.pose[2]) - parallax * float(rel[1])
        self.pose[2] = wrap_angle(self.pose[2] - heading_gain * r)
        left = left_of(frame[2])  # across the view's sight
        self.pose[:2] += cross_gain * r * left
        self.s = self.path.project(self.pose[:2], self.s, self.window)
        return float(r)

    def fix_across(self, view: int, offset: float, gain: float, gate: float) -> float:
        """Correct the offset across route view ``view``'s line of sight toward ``offset``.

        ``offset`` is in m, left positive (`servo.localise.ImageLocaliser.cross_offset`); the
        correction is the share ``gain`` of the difference; a measurement more than ``gate`` m
        from the belief is taken for a mismatch and ignored. Returns the innovation (m; NaN if
        ignored).

        Parameters
        ----------
        view : int
            The route view's index.
        offset : float
            The measured offset across the view's sight, m, left positive.
        gain : float
            The share of the innovation corrected.
        gate : float
            The largest innovation taken, m.

        Returns
        -------
        float
            The innovation, m; NaN where ignored.
        """
        frame = self.path.frames[int(view)]
        innovation = float(offset) - float(se2_relative(frame, self.pose)[1])
        if not abs(innovation) <= gate:
            return float("nan")
        self.pose[:2] += gain * innovation * left_of(frame[2])
        self.s = self.path.project(self.pose[:2], self.s, self.window)
        return innovation

    def measured(self, view: int, pose) -> np.ndarray:
        """Express a pose measured in route view ``view``'s frame in the route frame.

        The measured pose is x ahead along the view's sight, y left, yaw
        (`servo.camera_only.view_pose.ViewPose.pose`).

        Parameters
        ----------
        view : int
            The route view's index.
        pose : array_like of shape (3,)
            The pose (x ahead, y left, yaw) in the view's frame (m, m, rad).

        Returns
        -------
        numpy.ndarray
            The pose (x, y, yaw) in the route frame.
        """
        return se2_compose(self.path.frames[int(view)], np.asarray(pose, np.float64))

    def fix_pose(self, measured, gain: float, gate: float) -> float:
        """Correct the pose toward a ``measured`` pose in the route frame.

        The pose (`measured`) is taken by the share ``gain``, position and heading alike; a
        measurement more than ``gate`` m from the belief is taken for a mismatch and ignored.
        Returns the innovation's length (m; NaN if ignored).

        Parameters
        ----------
        measured : array_like of shape (3,)
            The measured pose (x, y, yaw) in the route frame (m, m, rad).
        gain : float
            The share of the innovation taken.
        gate : float
            The largest distance from the belief taken, m.

        Returns
        -------
        float
            The distance from the belief to ``measured``, m; NaN where ignored.
        """
        measured = np.asarray(measured, np.float64)
        innovation = measured[:2] - self.pose[:2]
        distance = float(np.hypot(*innovation))
        if not distance <= gate:
            return float("nan")
        self.pose[:2] += gain * innovation
        self.pose[2] = wrap_angle(self.pose[2] + gain * wrap_angle(measured[2] - self.pose[2]))
        self.s = self.path.project(self.pose[:2], self.s, self.window)
        return distance

    @staticmethod
    def reverse_gains(heading_gain: float, parallax: float) -> tuple[float, float]:
        """Return the reversing fix's gains per metre.

        They are |g1| = ``heading_gain`` and the cross gain g2 that puts both error modes of
        `fix_reversing` at one rate (critical damping: trace^2 = 4 det, g2 c - |g1| =
        2 sqrt(|g1| c)); the modes then decay as exp(-sqrt(|g1| c) s) over s metres reversed
        (~2.5 m in the hallway at |g1| = 1).

        Parameters
        ----------
        heading_gain : float
            |g1| per metre reversed, > 0.
        parallax : float
            The image shift per metre across a view's sight, c (rad/m), > 0.

        Returns
        -------
        heading_gain : float
            |g1|, per metre reversed.
        cross_gain : float
            g2, per metre reversed.
        """
        if not (heading_gain > 0 and parallax > 0):
            raise ValueError(f"gain and parallax must be > 0, got {heading_gain}, {parallax}")
        return heading_gain, (heading_gain + 2.0 * np.sqrt(heading_gain * parallax)) / parallax

    def bumped(self, direction: int, metres: float) -> None:
        """Move the belief away from a wall that stopped the robot.

        The robot was driving ``direction`` (+1 forward, -1 reversing) and is nearer that wall
        than believed. Where it was moving across the route (its direction of travel more than
        ~3 deg off the route's), the wall lies on that side, so the belief moves ``metres``
        that way across the route; the pursuit then steers away from it. Head-on (along the
        route) nothing is learnt across.

        Parameters
        ----------
        direction : int
            The direction the robot was driving: +1 forward, -1 reversing.
        metres : float
            How far the belief moves across the route, m.
        """
        a = self.path.point(max(self.s - 0.25, 0.0))
        b = self.path.point(min(self.s + 0.25, self.path.length))
        if float(np.hypot(*(b - a))) < 1e-6:
            return
        route = float(np.arctan2(b[1] - a[1], b[0] - a[0]))
        travel = self.pose[2] + (0.0 if direction > 0 else np.pi)
        across = float(np.sin(wrap_angle(travel - route)))
        if abs(across) < 0.05:
            return
        left = left_of(route)
        self.pose[:2] += float(np.sign(across)) * metres * left
        self.s = self.path.project(self.pose[:2], self.s, self.window)

    def shift_along(self, metres: float) -> None:
        """Move the belief ``metres`` along the route's direction at the current progress.

        An F peak passed says how far past a view the robot is.

        Parameters
        ----------
        metres : float
            The distance moved, m; negative moves it back.
        """
        a = self.path.point(self.s)
        b = self.path.point(self.s + 0.5)
        if self.s + 0.5 > self.path.length:
            a, b = self.path.point(self.s - 0.5), self.path.point(self.s)
        u = (b - a) / max(float(np.hypot(*(b - a))), 1e-9)
        self.pose[:2] += metres * u
        self.s = self.path.project(self.pose[:2], self.s, self.window)

    def goal(self, s: float) -> np.ndarray:
        """Return the route's point at arc ``s`` in the robot frame (x ahead, y left).

        Parameters
        ----------
        s : float
            The arc length along the route, m.

        Returns
        -------
        numpy.ndarray
            The point (x, y) in the robot frame, m.
        """
        return se2_relative(self.pose, np.r_[self.path.point(s), 0.0])[:2]


def left_of(heading: float) -> np.ndarray:
    """Return the unit vector 90 deg to the left of ``heading`` (rad): offsets across.

    Parameters
    ----------
    heading : float
        The heading, rad.

    Returns
    -------
    numpy.ndarray
        The unit vector (x, y).
    """
    return np.array([-np.sin(heading), np.cos(heading)])
