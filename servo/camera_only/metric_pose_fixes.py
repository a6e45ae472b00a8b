"""The metric pose fixes of [`SignalServo`][servo.camera_only.controller.SignalServo].

The whole image's shift against a route view measures the heading plus the parallax times the
offset across the view's sight (z = theta + c y) and cannot tell the two apart; only motion
does, slowly, and a robot held by a wall does not move. A metric pose against the view
(`ViewPose`: keypoints at the view's map-time depths, PnP)
measures both at once. `PoseFixes` takes such a pose every few steps against the route view
the image aligns with best, where the one before it agrees
(`PoseAgreement`), and moves the belief toward it; at the start
it can place the belief where the observing turn's images pose the robot against the global fix's
view, instead of at the view.
"""

from __future__ import annotations

import numpy as np

from common.geometry import se2_compose, se2_relative
from servo.camera_only.config import SignalServoConfig
from servo.camera_only.route_belief import RouteBelief
from servo.camera_only.view_pose import PoseAgreement, ViewPose
from servo.route import RoutePath


class PoseFixes:
    """Pose fixes for one controller (``config.pose_every`` > 0).

    Parameters
    ----------
    view_pose : ViewPose
        Poses images against stored views.
    config : SignalServoConfig
        The controller's settings (``pose_start``, ``pose_agree``, ``pose_gain``,
        ``pose_gate``).
    """

    def __init__(self, view_pose: ViewPose, config: SignalServoConfig):
        self.view_pose, self.config = view_pose, config
        self.turn_images: list[tuple[np.ndarray, np.ndarray]] = []
        self._turn_keypoints: dict[int, tuple] = {}  # turn image -> its ORB keypoints
        self._turn_poses: dict[tuple, list | None] = {}  # (view, image, image) -> their poses
        self._agreement: PoseAgreement | None = None

    def observe(self, image: np.ndarray, odometry: np.ndarray) -> None:
        """Keep an image of the observing turn (with ``pose_start``) and its odometry.

        Parameters
        ----------
        image : numpy.ndarray
            The camera image (H, W, 3) uint8.
        odometry : numpy.ndarray
            The odometry pose (x, y, theta) it was taken at.
        """
        if self.config.pose_start:
            self.turn_images.append((np.array(image), np.array(odometry, np.float64)))

    def _two_poses(self, view: int, distances: np.ndarray):
        """Pose the two turn images that matched ``view`` best against it.

        Returns their metric poses in ``view``'s frame, each with its odometry, in the order
        taken (``distances``: each kept image's aligned distance to ``view``); None where
        either gives none. Computed once per turn, view and
        pair of images (`supports` checks the fix's view, then `start` poses
        against it), each image's keypoints detected once (the check poses them against
        several views).
        """
        images = self.turn_images
        if len(images) != len(distances) or len(images) < 2:
            return None
        pair = tuple(int(i) for i in sorted(np.argsort(distances, kind="stable")[:2]))
        if (view, *pair) not in self._turn_poses:
            self._turn_poses[view, *pair] = self._posed_pair(view, pair)
        poses = self._turn_poses[view, *pair]
        if poses is None:
            return None
        return [(pose, images[i][1]) for pose, i in zip(poses, pair, strict=True)]

    def _posed_pair(self, view: int, pair: tuple[int, int]) -> list | None:
        """Pose turn images ``pair`` against ``view`` (None: either gives none)."""
        poses = []
        for i in pair:
            image = self.turn_images[i][0]
            if i not in self._turn_keypoints:
                self._turn_keypoints[i] = self.view_pose.keypoints(image)
            rel = self.view_pose.pose(image, view, self._turn_keypoints[i])
            if rel is None:
                return None
            poses.append(rel.pose)
        return poses

    def supports(self, view: int, distances: np.ndarray) -> bool:
        """Tell whether the observing turn supports a global fix on ``view`` metrically.

        It does where the two turn images that matched ``view`` best both pose against it and
        agree (``pose_agree``, carried by odometry from one to the other).

        Parameters
        ----------
        view : int
            The stored view of the fix.
        distances : numpy.ndarray
            Each kept turn image's aligned distance to ``view``, shape (S,).

        Returns
        -------
        bool
            Whether both images pose against ``view`` and their poses agree.
        """
        poses = self._two_poses(view, distances)
        if poses is None:
            return False
        (first, first_odo), (second, second_odo) = poses
        agreement = PoseAgreement(self.config.pose_agree or 0.3)
        agreement.agrees(first, first_odo)  # sets what the second is compared with
        return agreement.agrees(second, second_odo)

    def start(
        self, view: int, distances: np.ndarray, path: RoutePath, odometry: np.ndarray
    ) -> np.ndarray | None:
        """Place the robot in the route frame of ``path`` from the observing turn's poses.

        The route starts at the global fix's ``view``; the pose comes from the metric poses of
        the two turn images that matched ``view`` best (``distances``: each kept image's aligned
        distance to it), each carried by odometry to now, where they agree; else None. Starts a
        new route's agreement.

        Parameters
        ----------
        view : int
            The global fix's stored view, where the route starts.
        distances : numpy.ndarray
            Each kept turn image's aligned distance to ``view``, shape (S,).
        path : RoutePath
            The route from ``view``; its first frame places the poses in the route frame.
        odometry : numpy.ndarray
            The odometry pose (x, y, theta) now.

        Returns
        -------
        numpy.ndarray or None
            The robot's pose (x, y, yaw) in the route frame (m, m, rad); None where the two
            images give no poses or their poses do not agree.
        """
        self._agreement = PoseAgreement(self.config.pose_agree) if self.config.pose_agree else None
        poses = self._two_poses(view, distances)
        self.turn_images, self._turn_keypoints, self._turn_poses = [], {}, {}
        if poses is None:
            return None
        agreement = PoseAgreement(self.config.pose_agree or 0.3)
        for pose, odo in poses:
            measured = se2_compose(path.frames[0], pose)
            if agreement.agrees(measured, odo):
                return se2_compose(measured, se2_relative(odo, odometry))
        return None

    def fix(
        self,
        belief: RouteBelief,
        route_view: int,
        index: int,
        image: np.ndarray,
        odometry: np.ndarray,
    ) -> bool:
        """Move ``belief`` toward the metric pose of ``image`` against a route view.

        The pose against stored view ``route_view`` (route index ``index``) moves the belief
        (`fix_pose`) where the pose before it agrees (``pose_agree``). Returns whether it did.

        Parameters
        ----------
        belief : RouteBelief
            The pose on the route, moved in place.
        route_view : int
            The stored view posed against.
        index : int
            Its index on the route (into ``belief``'s path).
        image : numpy.ndarray
            The camera image (H, W, 3) uint8.
        odometry : numpy.ndarray
            The odometry pose (x, y, theta) now.

        Returns
        -------
        bool
            Whether the pose moved ``belief``.
        """
        rel = self.view_pose.pose(image, route_view)
        if rel is None:
            return False
        measured = belief.measured(index, rel.pose)
        if self._agreement is not None and not self._agreement.agrees(measured, odometry):
            return False
        c = self.config
        return bool(np.isfinite(belief.fix_pose(measured, c.pose_gain, c.pose_gate)))
