"""Where the camera is relative to a stored view, in metres.

Keypoints of the view with depth, matched in the current image, and the camera pose that
projects them there (PnP).

The whole image's best shift against a view (`servo.localise`) measures the heading plus
the parallax times the offset across the view's sight, z = theta + c y, and cannot tell the two
apart. Image points at known depths can: a turn moves near and far points alike, a step
sideways moves near points more. The stored view's depths come from the map, not from a
sensor at run time: the view's own laser scan, taken with it, gives the distance to the
vertical surface at each bearing (walls, furniture, fences), and the camera's height over a
flat floor gives the distance to the ground below the horizon; a keypoint takes the nearer of
the two. The pose is OpenCV's: ORB keypoints (``cv2.ORB_create``), ratio-tested Hamming
matches, ``cv2.solvePnPRansac`` with EPnP, then the inliers refined (Levenberg-Marquardt).

The depth model fails where the scan's plane (0.3 m above the floor) sees something the camera
(1 m above it) looks over: a hedge or a low wall with a house behind it. Those views give poses
off by a factor; `ViewPose.reliable` finds them from the map's own view graph (each view's
pose against its linked views, whose relative poses the map got by scan matching).
"""

from __future__ import annotations

from dataclasses import dataclass

import cv2
import numpy as np

from common.geometry import se2_compose, se2_relative, wrap_angle
from scenes.robot import CAMERA_FORWARD, CAMERA_FOVY, CAMERA_HEIGHT, LASER_FORWARD
from servo.maps import ServoMap

# Depth given to keypoints whose bearing the scan saw nothing at (beyond its range): far enough
# that a step of a metre barely moves them; they still fix the rotation.
# The depth models a view is verified with, in order: only the keypoints below the horizon
# (the floor, and the surfaces the scan hit wherever they stand below the camera), then all.
# Below the horizon first: on the lawn the scan's plane sees fences and hedges that the
# camera looks over at trees and houses, and the whole view's model passed the check there
# while posing worse (dev: 69 % of poses within 0.2 m across, against 80 %).
MODELS = (("ground", False), ("full", True))
FAR_DEPTH = 40.0
# A gap between two scan returns wider than this (rad) is not interpolated across.
SCAN_GAP = 0.05


@dataclass(frozen=True)
class RelativePose:
    """The robot (its axle, as the map's poses) in a stored view's frame.

    ``along`` m ahead of the view along its sight, ``left`` m to its left, ``yaw`` rad turned
    left from it; ``inliers`` of ``matches`` keypoint matches agreed with it.

    Parameters
    ----------
    along : float
        The distance ahead of the view along its sight, m.
    left : float
        The distance to the view's left, m.
    yaw : float
        The turn left from the view's heading, rad.
    inliers : int
        The keypoint matches that agreed with the pose (PnP inliers).
    matches : int
        The keypoint matches that passed the ratio test.
    """

    along: float
    left: float
    yaw: float
    inliers: int
    matches: int

    @property
    def pose(self) -> np.ndarray:
        """The pose as an array (``along``, ``left``, ``yaw``)."""
        return np.array([self.along, self.left, self.yaw])


@dataclass(frozen=True)
class _ViewPoints:
    points: np.ndarray  # (m, 3) in the view camera's frame (x right, y down, z ahead)
    descriptors: np.ndarray | None


class ViewPose:
    """Metric pose of the robot relative to stored views (see the module doc).

    Parameters
    ----------
    servo_map : ServoMap
        The map: its stored views' images, scans and view graph.
    n_features : int, default 500
        ORB keypoints per image.
    min_inliers : int, default 15
        The fewest PnP inliers that give a pose.
    reprojection : float, default 2.0
        RANSAC's inlier threshold, pixels.
    """

    def __init__(
        self,
        servo_map: ServoMap,
        n_features: int = 500,
        min_inliers: int = 15,
        reprojection: float = 2.0,
    ):
        if not isinstance(servo_map, ServoMap):
            raise TypeError(f"servo_map must be a ServoMap, got {type(servo_map).__name__}")
        if int(n_features) < 8 or int(min_inliers) < 6 or not reprojection > 0:
            raise ValueError(
                f"need n_features >= 8, min_inliers >= 6 and reprojection > 0, got "
                f"{n_features}, {min_inliers}, {reprojection}"
            )
        self.map = servo_map
        self.min_inliers, self.reprojection = int(min_inliers), float(reprojection)
        h, w = servo_map.images.shape[1:3]
        f = (h / 2.0) / np.tan(np.deg2rad(CAMERA_FOVY) / 2.0)
        self.K = np.array([[f, 0.0, w / 2.0], [0.0, f, h / 2.0], [0.0, 0.0, 1.0]])
        self._orb = cv2.ORB_create(int(n_features), fastThreshold=5, edgeThreshold=15, patchSize=15)
        self._matcher = cv2.BFMatcher(cv2.NORM_HAMMING)
        self._stored: dict[int, tuple] = {}  # view -> its image's ORB keypoints, descriptors
        self._views: dict[tuple[int, bool], _ViewPoints] = {}
        self._models: dict[int, str | None] = {}

    def keypoints(self, image: np.ndarray):
        """Detect the ORB keypoints and descriptors of a camera image (H, W, 3) uint8.

        Pass them to `pose` to pose one image against several views with one detection.

        Parameters
        ----------
        image : numpy.ndarray
            The RGB image (H, W, 3) uint8.

        Returns
        -------
        tuple
            OpenCV's (keypoints, descriptors): the ``cv2.KeyPoint`` objects and their (K, 32)
            uint8 descriptors (None where none were found).
        """
        image = np.asarray(image)
        if image.ndim != 3 or image.shape[2] != 3 or image.dtype != np.uint8:
            raise ValueError(f"image must be (H, W, 3) uint8, got {image.shape} {image.dtype}")
        return self._orb.detectAndCompute(cv2.cvtColor(image, cv2.COLOR_RGB2GRAY), None)

    def _stored_keypoints(self, view: int):
        """Return the ORB keypoints of stored view ``view``'s image, computed once.

        Both depth models of the view and the map check of its linked views use them.
        """
        if view not in self._stored:
            self._stored[view] = self.keypoints(self.map.images[view])
        return self._stored[view]

    def _view(self, view: int, upper: bool) -> _ViewPoints:
        if (view, upper) not in self._views:
            keypoints, descriptors = self._stored_keypoints(view)
            uv = np.array([k.pt for k in keypoints], np.float64).reshape(-1, 2)
            points = self.depth_points(view, uv, upper)
            self._views[view, upper] = _ViewPoints(points, descriptors)
        return self._views[view, upper]

    def depth_points(self, view: int, uv: np.ndarray, upper: bool = True) -> np.ndarray:
        """Return the 3-D points seen at pixels ``uv`` of stored view ``view``.

        Camera frame: x right, y down, z ahead. Along each pixel's ray, the nearer of the
        vertical surface the view's scan hit at that bearing (`FAR_DEPTH` where it hit nothing)
        and the floor (below the horizon, the camera `CAMERA_HEIGHT` above it).
        ``upper=False``: NaN above the horizon, where the scan's plane says nothing of what
        the camera sees over it (the lawn's trees and houses over its fences and hedges).

        Parameters
        ----------
        view : int
            The stored view.
        uv : numpy.ndarray of shape (M, 2)
            Pixel coordinates (u right, v down) in the view's image.
        upper : bool, default True
            Whether to give points above the horizon (else NaN there).

        Returns
        -------
        numpy.ndarray of shape (M, 3)
            The points (x, y, z) in the view camera's frame, m.
        """
        f, cx, cy = self.K[0, 0], self.K[0, 2], self.K[1, 2]
        r = np.asarray(self.map.scans[view], np.float64)
        a = np.asarray(self.map.angles, np.float64)
        hit = np.isfinite(r) & (r > 0) & (r < 0.999 * self.map.max_range)
        r = np.where(hit, r, 0.0)
        ahead = LASER_FORWARD + r * np.cos(a) - CAMERA_FORWARD  # in the camera's position
        side = r * np.sin(a)
        ok = hit & (ahead > 0.05)
        bearing, depth = np.arctan2(side[ok], ahead[ok]), ahead[ok]
        order = np.argsort(bearing)
        bearing, depth = bearing[order], depth[order]
        pixel_bearing = np.arctan2(cx - uv[:, 0], f)
        if bearing.size >= 2:
            wall = np.interp(pixel_bearing, bearing, depth, left=np.nan, right=np.nan)
            j = np.clip(np.searchsorted(bearing, pixel_bearing), 1, bearing.size - 1)
            wall[bearing[j] - bearing[j - 1] > SCAN_GAP] = np.nan
        else:
            wall = np.full(uv.shape[0], np.nan)
        wall = np.where(np.isfinite(wall), wall, FAR_DEPTH)
        below = uv[:, 1] - cy
        floor = np.where(below > 0.5, CAMERA_HEIGHT * f / np.maximum(below, 1e-9), np.inf)
        z = np.minimum(wall, floor)
        if not upper:
            z = np.where(below > 0.5, z, np.nan)
        return np.stack([(uv[:, 0] - cx) / f * z, below / f * z, z], axis=1)

    def pose(self, image: np.ndarray, view: int, keypoints=None) -> RelativePose | None:
        """Pose the robot in stored view ``view``'s frame from the camera ``image``.

        With the view's verified depth model (`depth_model`); None where the view has none or
        too few keypoints match or agree. ``keypoints``: the image's `keypoints`, if already
        detected.

        Parameters
        ----------
        image : numpy.ndarray
            The camera image (H, W, 3) uint8.
        view : int
            The stored view.
        keypoints : tuple, optional
            The image's (keypoints, descriptors) from `keypoints`; detected here if None.

        Returns
        -------
        RelativePose or None
            The robot's pose in the view's frame; None where there is none.
        """
        model = self.depth_model(view)
        return None if model is None else self.relative(image, view, model == "full", keypoints)

    def relative(
        self, image: np.ndarray, view: int, upper: bool = True, keypoints=None
    ) -> RelativePose | None:
        """Pose the robot in stored view ``view``'s frame from the camera ``image``.

        The view's keypoints above the horizon are used only with ``upper``; None where too
        few keypoints match or agree (fewer than ``min_inliers``).

        Parameters
        ----------
        image : numpy.ndarray
            The camera image (H, W, 3) uint8.
        view : int
            The stored view.
        upper : bool, default True
            Whether the view's keypoints above the horizon are used.
        keypoints : tuple, optional
            The image's (keypoints, descriptors) from `keypoints`; detected here if None.

        Returns
        -------
        RelativePose or None
            The robot's pose in the view's frame; None where there is none.
        """
        view = self.map.check_view(view, "view")
        keypoints = self.keypoints(image) if keypoints is None else keypoints
        return self._posed(keypoints, view, bool(upper))

    def _posed(self, image_keypoints, view: int, upper: bool) -> RelativePose | None:
        """`relative` from the image's ORB ``(keypoints, descriptors)``."""
        stored = self._view(view, upper)
        keypoints, descriptors = image_keypoints
        if stored.descriptors is None or descriptors is None or len(keypoints) < 8:
            return None
        pairs = self._matcher.knnMatch(stored.descriptors, descriptors, k=2)
        good = [p[0] for p in pairs if len(p) == 2 and p[0].distance < 0.8 * p[1].distance]
        if len(good) < self.min_inliers:
            return None
        P = stored.points[[g.queryIdx for g in good]]
        uv = np.array([keypoints[g.trainIdx].pt for g in good], np.float64)
        keep = np.isfinite(P[:, 2])
        P, uv = P[keep], uv[keep]
        if len(P) < self.min_inliers:
            return None
        # RANSAC's draws come from OpenCV's own fixed-seed generator: the same images give the
        # same pose on every run.
        ok, rvec, tvec, inliers = cv2.solvePnPRansac(
            P,
            uv,
            self.K,
            None,
            iterationsCount=200,
            reprojectionError=self.reprojection,
            flags=cv2.SOLVEPNP_EPNP,
        )
        if not ok or inliers is None or len(inliers) < self.min_inliers:
            return None
        idx = inliers.ravel()
        ok, rvec, tvec = cv2.solvePnP(
            P[idx], uv[idx], self.K, None, rvec, tvec, True, cv2.SOLVEPNP_ITERATIVE
        )
        if not ok:
            return None
        R, _ = cv2.Rodrigues(rvec)
        yaw = float(np.arctan2(R[0, 2], R[0, 0]))  # a left turn about the camera's -y
        centre = (-R.T @ tvec).ravel()  # this camera in the view camera's frame
        # camera -> robot axle: the camera sits CAMERA_FORWARD ahead of the axle
        along = centre[2] + CAMERA_FORWARD - CAMERA_FORWARD * np.cos(yaw)
        left = -centre[0] - CAMERA_FORWARD * np.sin(yaw)
        if not np.all(np.isfinite([along, left, yaw])):
            return None
        return RelativePose(float(along), float(left), yaw, int(idx.size), len(good))

    def depth_model(self, view: int, tolerance: float = 0.25) -> str | None:
        """Return the depth model poses against ``view`` can be trusted with.

        "ground" (only the keypoints below the horizon), else "full" (every keypoint), else
        None.

        A model is trusted where each stored view linked to ``view`` in the map's view graph,
        posed against it, comes within ``tolerance`` m (and ``tolerance`` / 5 rad) of the
        link's scan-matched relative pose, and at least one is posed. Computed once per view.

        Parameters
        ----------
        view : int
            The stored view.
        tolerance : float, default 0.25
            The largest position error of a linked view's pose, m (heading: ``tolerance`` / 5
            rad).

        Returns
        -------
        str or None
            "ground", "full", or None where neither model agrees with the view graph.
        """
        view = self.map.check_view(view, "view")
        if view not in self._models:
            self._models[view] = next(
                (name for name, upper in MODELS if self._agrees(view, upper, tolerance)), None
            )
        return self._models[view]

    def _agrees(self, view: int, upper: bool, tolerance: float) -> bool:
        found = 0
        for other, pose in self._linked(view):
            rel = self._posed(self._stored_keypoints(other), view, upper)
            if rel is None:
                continue
            found += 1
            err = rel.pose - pose
            if np.hypot(err[0], err[1]) > tolerance or abs(wrap_angle(err[2])) > tolerance / 5:
                return False
        return found > 0

    def _linked(self, view: int):
        """(other view, its pose in ``view``'s frame) for every view-graph link of ``view``."""
        E, T = self.map.edges, self.map.edge_transforms
        for e in np.flatnonzero(E[:, 0] == view):
            yield int(E[e, 1]), np.asarray(T[e], np.float64)
        for e in np.flatnonzero(E[:, 1] == view):
            yield int(E[e, 0]), se2_relative(T[e], np.zeros(3))


class PoseAgreement:
    """Take a measured pose only when the one before it, carried by odometry to now, agrees.

    A pose from keypoints that matched a repeated texture (a brick wall, a row of doors) is
    far off but rare, and two of them seldom agree.

    Parameters
    ----------
    distance : float, default 0.3
        The distance (m) within which the two positions must agree; the headings must agree
        within ``distance`` / 3 rad.
    """

    def __init__(self, distance: float = 0.3):
        if not distance > 0:
            raise ValueError(f"distance must be > 0 m, got {distance}")
        self.distance = float(distance)
        self.reset()

    def reset(self) -> None:
        """Forget the last measurement (a new route frame)."""
        self._last: tuple[np.ndarray, np.ndarray] | None = None

    def agrees(self, measured, odometry) -> bool:
        """Tell whether ``measured`` agrees with the last measurement carried by odometry.

        ``measured`` is (x, y, yaw) in the route frame, the last measurement is moved by the
        odometry (x, y, yaw) since; ``measured`` becomes the last.

        Parameters
        ----------
        measured : array_like of shape (3,)
            The measured pose (x, y, yaw) in the route frame (m, m, rad).
        odometry : array_like of shape (3,)
            The odometry pose (x, y, yaw) at the measurement.

        Returns
        -------
        bool
            Whether the two agree; False for the first measurement.
        """
        measured, odometry = np.asarray(measured, np.float64), np.asarray(odometry, np.float64)
        last, self._last = self._last, (measured.copy(), odometry.copy())
        if last is None:
            return False
        carried = se2_compose(last[0], se2_relative(last[1], odometry))
        err = measured - carried
        return bool(
            np.hypot(err[0], err[1]) <= self.distance
            and abs(wrap_angle(err[2])) <= self.distance / 3
        )
