"""A local position fix where a route turns from reversing out of one branch to driving
forward into another (junction turns of
[`SignalServo`][servo.camera_only.controller.SignalServo]).

Reversing out of a branch, the robot's offset across the branch is weakly observable (the
image's best shift against a view is z = theta + c y: heading and offset mixed, c the map's
parallax, `parallax`), so it arrives at the junction
with its position up to ~1 m off, and turning on the spot there it would enter the wrong
opening or a wall. At a junction, though, stored views look along *different* corridors (the
one it came from, the one it turns into, the main one), and the shifts against views of
several headings tell the position: each match of an image taken at belief heading h against
a view k at (x_k, y_k, phi_k) says

    phi_k - yaw = h + delta + c * lat_k(x, y),   lat_k = -sin(phi_k)(x - x_k) + cos(phi_k)(y - y_k)

(the robot's offset left of view k's line of sight), which is linear in the heading offset
delta and the position (x, y). `pose_from_turn` solves the matches of the turn toward
the new heading for them by least squares, with a prior at the belief. Views of one heading
leave the position along their sight to the prior; with two, a heading offset trades against a
diagonal shift, so the heading's prior decides it; three fix all three. Views' poses come from
the view graph's sensed transforms (`neighbourhood`); no
ground truth.

Dev result (docs/guides/servo.md): the position fix moved the belief the wrong way as
often as the right way (the parallax near a junction is 2-4x the map's; views on a curve
leave the along-sight position ill-conditioned), and the turn alone did not help either; both
are off in [`SignalServoConfig`][servo.camera_only.config.SignalServoConfig] (``junction_fix``,
``junction_position``).
"""

from __future__ import annotations

import numpy as np

from common.geometry import se2_compose, wrap_angle
from servo.camera_only.turn_global_fix import neighbourhood
from servo.steering import turn_on_spot

__all__ = ["JunctionTurn", "pose_from_turn", "views_near"]


def pose_from_turn(
    headings,
    views,
    yaws,
    weights,
    parallax: float,
    prior,
    *,
    sigma_shift: float = 0.03,
    sigma_xy: float = 1.0,
    sigma_heading: float = 0.2,
) -> tuple[np.ndarray, float]:
    """The position and heading offset that best explain a turn's image matches.

    Parameters
    ----------
    headings : (n,) belief heading (rad) at each match (odometry carries it through the turn).
    views : (n, 3) the matched view's pose (x, y, phi) in the belief's frame.
    yaws : (n,) the match's best shift as a turn (rad, `ImageLocaliser.align`).
    weights : (n,) >= 0, each match's weight (e.g. 1 - distance / trust).
    parallax : c, rad of shift per m across a view's sight (> 0).
    prior : (x, y) the belief's position, the prior's mean (delta's is 0).
    sigma_shift / sigma_xy / sigma_heading : the shift's noise (rad), the prior's spread in
        position (m) and heading (rad).

    Returns
    -------
    xy : (2,) the position; delta : the heading correction (rad) to add to the belief's.
    """
    h = np.asarray(headings, np.float64).ravel()
    v = np.asarray(views, np.float64).reshape(-1, 3)
    yaw = np.asarray(yaws, np.float64).ravel()
    w = np.asarray(weights, np.float64).ravel()
    if not len(h) == len(v) == len(yaw) == len(w):
        raise ValueError("headings, views, yaws and weights must be equally long")
    if not parallax > 0:
        raise ValueError(f"parallax must be > 0, got {parallax}")
    if np.any(w < 0) or not np.all(np.isfinite(np.r_[h, v.ravel(), yaw, w])):
        raise ValueError("weights must be >= 0 and every input finite")
    prior = np.asarray(prior, np.float64)
    sin, cos = np.sin(v[:, 2]), np.cos(v[:, 2])
    # row: delta + c (-sin x + cos y) = wrap(phi - yaw - h) + c (-sin x_k + cos y_k)
    A = np.column_stack([np.ones(len(h)), -parallax * sin, parallax * cos])
    b = wrap_angle(v[:, 2] - yaw - h) + parallax * (-sin * v[:, 0] + cos * v[:, 1])
    info = np.diag([sigma_heading**-2, sigma_xy**-2, sigma_xy**-2])
    mean = np.array([0.0, prior[0], prior[1]])
    wa = A * (w / sigma_shift**2)[:, None]
    u = np.linalg.solve(A.T @ wa + info, wa.T @ b + info @ mean)
    return u[1:], float(u[0])


def views_near(routes, path, route: list[int], index: int, centre, radius: float):
    """The stored views within ``radius`` m of ``centre`` (route frame), any recording's,
    with their poses in the route frame: the view graph's sensed transforms chained from
    route view ``route[index]`` (`neighbourhood`). Returns
    (views (m,), poses (m, 3)).
    """
    near = neighbourhood(routes, route[index], radius + 2.0)
    views = np.array(sorted(near), np.intp)
    poses = np.array([se2_compose(path.frames[index], near[int(v)]) for v in views])
    keep = np.hypot(*(poses[:, :2] - np.asarray(centre, np.float64)[:2]).T) <= radius
    return views[keep], poses[keep].reshape(-1, 3)


class JunctionTurn:
    """Where the route turns from reversing to driving forward: turn on the spot to the
    forward heading, matching every image against the stored views nearby that look about
    the way the robot faces, then move the belief to `pose_from_turn`'s fix.

    ``views`` / ``poses``: the candidates (`views_near`); ``heading``: the forward
    heading (route frame); ``trust``: largest aligned distance that counts; ``facing``: rad
    within which a view's heading must lie of the robot's to be compared; ``max_shift``: a
    fix that would move the belief farther (m) is dropped; ``sigma_heading``: the prior's
    spread of the heading (rad; after reversing, odometry's heading is good to ~0.1 rad);
    ``fix``: False turns without moving the belief (the turn alone).
    """

    def __init__(
        self,
        views,
        poses,
        heading: float,
        parallax: float,
        *,
        trust: float,
        facing: float,
        turn_rate: float,
        max_shift: float = 2.5,
        sigma_heading: float = 0.1,
        fix: bool = True,
    ):
        self.views, self.poses = np.asarray(views, np.intp), np.asarray(poses, np.float64)
        self.heading, self.parallax = float(heading), float(parallax)
        self.trust, self.facing, self.turn_rate = float(trust), float(facing), float(turn_rate)
        self.max_shift, self.sigma_heading = float(max_shift), float(sigma_heading)
        self.fix = bool(fix)
        self.samples: list[tuple[float, int, float, float]] = []  # heading, candidate, yaw, w
        self.steps = 0
        self.shift_ = None  # m the fix moved the belief (None: not applied)

    @classmethod
    def on_route(
        cls, routes, belief, route: list[int], index: int, config, parallax: float
    ) -> JunctionTurn:
        """The turn at route view ``route[index]`` toward its heading, the candidates near
        the ``belief`` (`views_near`), with ``config``'s junction settings
        ([`SignalServoConfig`][servo.camera_only.config.SignalServoConfig]) and the map's
        ``parallax``.
        """
        c = config
        views, poses = views_near(
            routes, belief.path, route, index, belief.pose[:2], c.junction_radius
        )
        return cls(
            views,
            poses,
            float(belief.path.frames[index, 2]),
            c.junction_parallax * parallax,
            trust=c.image_trust,
            facing=c.facing,
            turn_rate=c.turn_rate,
            fix=c.junction_position,
        )

    def step(self, belief, x, localiser, dt: float) -> np.ndarray | None:
        """The turn's command for this image, or None once done (the belief fixed)."""
        self.steps += 1
        h = float(belief.pose[2])
        if len(self.views):
            sel = np.flatnonzero(np.abs(wrap_angle(self.poses[:, 2] - h)) < self.facing)
            if len(sel):
                d, yaw = localiser.align(x, self.views[sel])
                k = int(np.argmin(d))
                if d[k] <= self.trust:
                    self.samples.append((h, int(sel[k]), float(yaw[k]), 1.0 - d[k] / self.trust))
        err = float(wrap_angle(self.heading - h))
        if abs(err) > 0.05 and self.steps < int(2 * np.pi / (self.turn_rate * dt)):
            return turn_on_spot(err, self.turn_rate, dt)
        self._apply(belief)
        return None

    def _apply(self, belief) -> None:
        if not self.fix or len(self.samples) < 3:
            return
        h, k, yaw, w = (np.array(a) for a in zip(*self.samples, strict=True))
        xy, delta = pose_from_turn(
            h,
            self.poses[k.astype(np.intp)],
            yaw,
            w,
            self.parallax,
            belief.pose[:2],
            sigma_heading=self.sigma_heading,
        )
        moved = float(np.hypot(*(xy - belief.pose[:2])))
        if moved > self.max_shift:  # an outlier: keep odometry's
            return
        belief.pose[:2] = xy
        belief.pose[2] = wrap_angle(belief.pose[2] + delta)
        belief.s = belief.path.project(belief.pose[:2], belief.s, belief.window)
        self.shift_ = moved
