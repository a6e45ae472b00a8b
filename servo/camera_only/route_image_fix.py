"""The image fixes of the camera-only controller's belief on its route.

The belief is [`SignalServo`][servo.camera_only.controller.SignalServo]'s. Each step the image
is aligned with the route views about the belief's progress that look the way the robot faces,
and the best of them corrects the belief (`RouteBelief`): every ``pose_every`` steps by the
metric pose against it (`PoseFixes`), else by its horizontal shift (the heading, eq. 13's
best-aligned view), its place on the route (the position along it) and, where the map resolves
it, the near ground's extra shift (the offset across it). `RouteImageFix` holds what the fixes
need of the controller and says whether the image matched, so the controller can count the steps
it has been lost.
"""

from __future__ import annotations

import numpy as np

from servo.camera_only.config import SignalServoConfig
from servo.camera_only.metric_pose_fixes import PoseFixes
from servo.camera_only.route_belief import RouteBelief
from servo.localise import ImageLocaliser
from sim.simulator import CONTROL_DT

__all__ = ["RouteImageFix"]


class RouteImageFix:
    """Image and metric pose fixes of a belief on a route, for one controller.

    Parameters
    ----------
    localiser : ImageLocaliser
        Aligns images with the map's stored views.
    config : SignalServoConfig
        The controller's settings.
    poses : PoseFixes or None
        The metric pose fixes (None: ``pose_every`` is 0).
    far_scene : bool
        Whether the map's parallax is below ``config.reverse_parallax``: image fixes then need
        a sharp alignment (``fix_contrast``).
    parallax : float
        The map's image shift per metre across a view's sight (rad/m), the reversing fix's model.
    cross_parallax : float
        The near ground's extra shift per metre across (rad/m); 0 where the map does not
        resolve it (no fix across).
    """

    def __init__(
        self,
        localiser: ImageLocaliser,
        config: SignalServoConfig,
        poses: PoseFixes | None,
        *,
        far_scene: bool,
        parallax: float,
        cross_parallax: float,
    ):
        self.localiser, self.config, self.poses = localiser, config, poses
        self.far_scene, self.parallax = bool(far_scene), float(parallax)
        self.cross_parallax = float(cross_parallax)

    def fix(
        self,
        belief: RouteBelief,
        route: list[int],
        x: np.ndarray,
        image: np.ndarray,
        odometry: np.ndarray,
        steps: int,
        *,
        reversing: bool,
        following: bool,
    ) -> bool | None:
        """Correct ``belief`` by the route view the image matches best.

        The views compared are those about the current progress that look the way the robot
        faces (none: odometry alone).

        The image's shift mixes the heading with the offset across the route (a robot right
        of a view must turn left to line up with it). Driving forward, correcting the heading
        by it steers the robot back onto the route (a funnel); reversing, the same correction
        would push it away, so a reversing robot takes the reverse-stable fix
        (`fix_reversing`), and none in the
        arrival's sweep. At the target only the heading is fixed: the route ends there, so
        beyond it the best view is always the last, and the F peak places the robot along the
        view's sight.

        Parameters
        ----------
        belief : RouteBelief
            The pose on the route, corrected in place.
        route : list of int
            The route's stored views (``belief``'s indices are into it).
        x : numpy.ndarray
            The image's features (`features`).
        image : numpy.ndarray
            The image itself (metric pose fixes detect keypoints in it).
        odometry : numpy.ndarray
            The odometry pose (x, y, theta) now.
        steps : int
            The controller's steps so far (a pose fix every ``pose_every``).
        reversing : bool
            Whether the last command drove backwards.
        following : bool
            Whether the controller follows the route (False: it arrives at the target).

        Returns
        -------
        bool or None
            True where a route view matched and fixed the belief, False where none matched
            well enough (``image_trust``), None where no view was compared (none faces the
            robot's way, or a reversing arrival, which takes metric pose fixes only).
        """
        c, b = self.config, belief
        near = b.facing(b.path.within(b.s, c.behind, c.ahead), c.facing)
        reverse_fix = reversing and following
        if len(near) == 0:
            return None
        if reversing and not reverse_fix:
            self.pose_fix(b, route, x, near, image, odometry, steps)
            return None
        d, yaw, contrast = self.localiser.align_contrast(x, [route[i] for i in near])
        if self.far_scene:
            # grass and sky match a view turned 0.7 rad away almost equally at every shift
            # (a dev trace: after the arrival's turn on the spot such fixes turned the
            # belief's heading 0.45 rad the wrong way); only a sharp minimum gives a heading
            d = np.where(contrast <= c.fix_contrast, d, np.inf)
        k = int(np.argmin(d))
        if d[k] <= c.image_trust and self.pose_fix(
            b, route, x, near[k : k + 1], image, odometry, steps
        ):
            return True
        if not d[k] <= c.image_trust:
            return False
        # "Best among its neighbours" places the robot at the view only if there are
        # neighbours on both sides: past the last view that faces its way (a junction
        # where the route turns) the end view stays the best and would pin the belief
        # there while the robot drives on.
        interior = 0 < k < len(near) - 1
        along = c.along_gain if following and interior else 0.0
        if reverse_fix:
            metres = c.reverse_speed * CONTROL_DT  # the gains are per metre reversed
            # no fix along the route (see fix_reversing); odometry's distance is good
            # over a route's length
            g1, g2 = b.reverse_gains(c.reverse_heading_gain, self.parallax)
            b.fix_reversing(int(near[k]), float(yaw[k]), self.parallax, g1 * metres, g2 * metres)
        else:
            b.fix(int(near[k]), float(yaw[k]), c.heading_gain, along)
        if self.cross_parallax > 0 and c.cross_gain > 0:
            across = self.localiser.cross_offset(x, route[near[k]], self.cross_parallax)
            if np.isfinite(across):
                b.fix_across(int(near[k]), across, c.cross_gain, c.cross_gate)
        return True

    def pose_fix(
        self,
        belief: RouteBelief,
        route: list[int],
        x: np.ndarray,
        near: np.ndarray,
        image: np.ndarray,
        odometry: np.ndarray,
        steps: int,
    ) -> bool:
        """Fix ``belief`` by a metric pose every ``pose_every`` steps.

        The pose is against the best-aligned of the route views ``near`` (indices into
        ``route``; `PoseFixes`). Returns whether it moved ``belief``.

        Parameters
        ----------
        belief : RouteBelief
            The pose on the route, corrected in place.
        route : list of int
            The route's stored views.
        x : numpy.ndarray
            The image's features.
        near : numpy.ndarray
            The route views compared (indices into ``route``).
        image : numpy.ndarray
            The image itself (the pose fix detects keypoints in it).
        odometry : numpy.ndarray
            The odometry pose (x, y, theta) now.
        steps : int
            The controller's steps so far (a pose fix every ``pose_every``).

        Returns
        -------
        bool
            Whether a metric pose moved ``belief``.
        """
        if self.poses is None or steps % self.config.pose_every or len(near) == 0:
            return False
        if len(near) > 1:
            d = self.localiser.align(x, [route[i] for i in near])[0]
            near = near[[int(np.argmin(d))]]
        k = int(near[0])
        return self.poses.fix(belief, route[k], k, image, odometry)
