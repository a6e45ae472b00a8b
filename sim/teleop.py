"""A scripted teleoperator: a waypoint follower with human-like speed and heading jitter.

It drives the route by pure pursuit toward a look-ahead point that wanders smoothly to either
side of the route (people do not walk a centre line), with Ornstein-Uhlenbeck noise on speed
and turn rate. Another seed gives another realistic pass along the same route.
"""

from __future__ import annotations

from dataclasses import asdict, dataclass, replace

import numpy as np

from common.geometry import wrap_angle
from scenes import World
from scenes.regions import Route
from scenes.robot import RADIUS

# The largest ``TeleopConfig.scaled`` jitter: at 2 the scripted driver finished every route of
# seeds 0-59 (and of the randomised worlds of seeds 0-29); at 3 it stalled on 4 of 60 seeds
# (started against a wall or wandered into a corner), at 10 on every seed tried.
MAX_JITTER = 2.0


@dataclass(frozen=True)
class TeleopConfig:
    """Driver settings of the scripted teleoperator.

    Parameters
    ----------
    speed : float, default 0.6
        Nominal speed, m/s.
    speed_jitter : float, default 0.12
        Relative speed jitter.
    turn_jitter : float, default 0.12
        Turn-rate jitter, rad/s.
    lateral_wander : float, default 0.25
        Lateral wander, m.
    wander_length : float, default 3.0
        The wander's correlation length, m.
    lookahead : float, default 1.2
        Pure-pursuit look-ahead, m.
    start_jitter : (float, float), default (0.15, 0.08)
        The start pose's jitter (m, rad).
    """

    speed: float = 0.6
    speed_jitter: float = 0.12
    turn_jitter: float = 0.12
    lateral_wander: float = 0.25
    wander_length: float = 3.0
    lookahead: float = 1.2
    start_jitter: tuple[float, float] = (0.15, 0.08)

    def __post_init__(self):
        """Check the settings: all finite and >= 0; speed, lookahead, wander_length > 0."""
        for k, v in asdict(self).items():
            vals = np.ravel(v)
            if not np.all(np.isfinite(vals)) or np.any(vals < 0):
                raise ValueError(f"teleop {k} must be finite and >= 0, got {v}")
        if self.speed <= 0 or self.lookahead <= 0 or self.wander_length <= 0:
            raise ValueError("teleop speed, lookahead and wander_length must be > 0")

    def scaled(self, jitter: float) -> TeleopConfig:
        """Return the same driver with every random term times ``jitter``.

        The random terms are speed and turn jitter, lateral wander and start jitter: 0 drives
        the route's centre line at constant speed, the same pass for every seed; 1 is this
        config; at most `MAX_JITTER`, beyond which the driver can stall before the route's
        end.

        Parameters
        ----------
        jitter : float
            The factor, in ``[0, MAX_JITTER]``.

        Returns
        -------
        TeleopConfig
            The scaled settings.
        """
        if not (np.isfinite(jitter) and jitter >= 0):
            raise ValueError(f"teleop jitter must be a finite number >= 0, got {jitter}")
        if jitter > MAX_JITTER:
            raise ValueError(
                f"teleop jitter must be at most {MAX_JITTER} (a wilder driver can stall before "
                f"the route's end), got {jitter}"
            )
        return replace(
            self,
            speed_jitter=self.speed_jitter * jitter,
            turn_jitter=self.turn_jitter * jitter,
            lateral_wander=self.lateral_wander * jitter,
            start_jitter=tuple(v * jitter for v in self.start_jitter),
        )


class Polyline:
    """Arc-length parametrised route: ``point(s)``, ``tangent(s)``, ``project(xy)``.

    Parameters
    ----------
    waypoints : ndarray of shape (n, 2)
        The route's points, in order.
    """

    def __init__(self, waypoints: np.ndarray):
        self.p = np.asarray(waypoints, np.float64)
        seg = np.diff(self.p, axis=0)
        self.seg_len = np.linalg.norm(seg, axis=1)
        self.dirs = seg / self.seg_len[:, None]
        self.cum = np.concatenate([[0.0], np.cumsum(self.seg_len)])
        self.length = float(self.cum[-1])

    def point(self, s: float) -> np.ndarray:
        """Return the route's point at arc length ``s`` (clipped to the route).

        Parameters
        ----------
        s : float
            Arc length, m.

        Returns
        -------
        ndarray of shape (2,)
            The point.
        """
        s = float(np.clip(s, 0.0, self.length))
        i = min(int(np.searchsorted(self.cum, s, side="right")) - 1, len(self.seg_len) - 1)
        return self.p[i] + self.dirs[i] * (s - self.cum[i])

    def tangent(self, s: float) -> np.ndarray:
        """Return the route's unit direction at arc length ``s`` (clipped to the route).

        Parameters
        ----------
        s : float
            Arc length, m.

        Returns
        -------
        ndarray of shape (2,)
            The unit direction of the segment there.
        """
        s = float(np.clip(s, 0.0, self.length))
        i = min(int(np.searchsorted(self.cum, s, side="right")) - 1, len(self.seg_len) - 1)
        return self.dirs[i]

    def project(self, xy, lo: float = 0.0, hi: float | None = None) -> float:
        """Return the arc length of the closest route point to ``xy`` among s in [lo, hi].

        Parameters
        ----------
        xy : array-like of shape (2,)
            The point.
        lo : float, default 0.0
            The least arc length, m.
        hi : float, optional
            The greatest arc length, m; the route's length when None.

        Returns
        -------
        float
            The arc length, m.
        """
        hi = self.length if hi is None else hi
        rel = np.asarray(xy, np.float64) - self.p[:-1]
        t = np.clip(np.einsum("ij,ij->i", rel, self.dirs), 0.0, self.seg_len)
        s = np.clip(self.cum[:-1] + t, lo, hi)
        pts = np.array([self.point(v) for v in s])
        return float(s[np.argmin(np.linalg.norm(pts - xy, axis=1))])


class ScriptedTeleop:
    """Drives one route. Call `start_pose` once, then `command` every step.

    Parameters
    ----------
    world : scenes.World
        The world, whose free space keeps the look-ahead point where the robot fits.
    route : scenes.regions.Route
        The route to drive.
    config : TeleopConfig
        The driver's settings.
    rng : numpy.random.Generator
        Draws the start jitter and the noises.
    """

    def __init__(self, world: World, route: Route, config: TeleopConfig, rng: np.random.Generator):
        self.route = Polyline(route.waypoints)
        self.config = config
        self.rng = rng
        # Keep the wandering look-ahead point where the robot fits, with a margin.
        self.free = world.free_space(resolution=0.05, inflation=RADIUS + 0.15)
        self.progress = 0.0
        self._speed_noise = 0.0
        self._turn_noise = 0.0
        self._offset = 0.0

    def start_pose(self) -> np.ndarray:
        """Draw the start pose: the route's start and heading, jittered.

        Returns
        -------
        ndarray of shape (3,)
            ``(x, y, yaw)``.
        """
        c = self.config
        p = self.route.point(0.0) + self.rng.normal(0.0, c.start_jitter[0], 2)
        t = self.route.tangent(0.0)
        yaw = np.arctan2(t[1], t[0]) + self.rng.normal(0.0, c.start_jitter[1])
        return np.array([p[0], p[1], float(wrap_angle(yaw))])

    @property
    def done(self) -> bool:
        """Whether the driver is within 5 cm of the route's end."""
        return self.progress >= self.route.length - 0.05

    def command(self, pose: np.ndarray, dt: float) -> tuple[float, float]:
        """Return (v, omega) toward the wandering look-ahead point; advance `progress`.

        Parameters
        ----------
        pose : ndarray of shape (3,)
            The robot's pose ``(x, y, yaw)``.
        dt : float
            The control step, s (for the noises).

        Returns
        -------
        tuple of (float, float)
            ``(v, omega)`` in m/s and rad/s.
        """
        c = self.config
        self.progress = self.route.project(pose[:2], self.progress - 0.5, self.progress + 2.0)
        # Ornstein-Uhlenbeck noises (exact discretisation, unit-free correlation times).
        for name, sigma, tau in (
            ("_speed_noise", c.speed_jitter, 2.0),
            ("_turn_noise", c.turn_jitter, 1.0),
        ):
            a = np.exp(-dt / tau)
            setattr(
                self, name, a * getattr(self, name) + sigma * np.sqrt(1 - a * a) * self.rng.normal()
            )
        a = np.exp(-c.speed * dt / c.wander_length)
        self._offset = a * self._offset + c.lateral_wander * np.sqrt(1 - a * a) * self.rng.normal()
        s_target = min(self.progress + c.lookahead, self.route.length)
        t = self.route.tangent(s_target)
        normal = np.array([-t[1], t[0]])
        target = self.route.point(s_target)
        for shrink in (1.0, 0.5, 0.0):
            candidate = target + shrink * self._offset * normal
            if self.free.is_free(candidate):
                target = candidate
                break
        dx, dy = target - pose[:2]
        alpha = float(wrap_angle(np.arctan2(dy, dx) - pose[2]))
        dist = max(float(np.hypot(dx, dy)), 1e-6)
        remaining = self.route.length - self.progress
        v = c.speed * (1.0 + self._speed_noise) * max(np.cos(alpha), 0.0)
        v = min(v, 0.6 * remaining + 0.1)  # ease into the final waypoint
        omega = 2.0 * max(v, 0.2) * np.sin(alpha) / dist + self._turn_noise
        return float(max(v, 0.0)), float(omega)
