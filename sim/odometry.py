"""Wheel odometry: the true motion between two poses, corrupted by noise and integrated.

Each increment is taken in the robot frame (forward, sideways, turn). Noise is a random walk
whose *variance* grows linearly with the distance driven and the angle turned, so the drift
after a route does not depend on how finely the route was stepped (a noise whose standard
deviation is proportional to each step would vanish as steps get smaller).
"""

from __future__ import annotations

from dataclasses import asdict, dataclass

import numpy as np

from common.geometry import wrap_angle


@dataclass(frozen=True)
class OdometryConfig:
    """Odometry noise densities; all zero gives perfect dead reckoning.

    Defaults drift about 0.1 rad and 1 m over the 40 m of a default route.

    Parameters
    ----------
    translation : float, default 0.02
        m per sqrt(m) driven (forward distance error).
    heading_per_metre : float, default 0.015
        rad per sqrt(m) driven (wheel-diameter mismatch, slip).
    heading_per_radian : float, default 0.03
        rad per sqrt(rad) turned.
    """

    translation: float = 0.02
    heading_per_metre: float = 0.015
    heading_per_radian: float = 0.03

    def __post_init__(self):
        """Check that every density is finite and >= 0."""
        for k, v in asdict(self).items():
            if not np.isfinite(v) or v < 0:
                raise ValueError(f"odometry {k} must be a finite number >= 0, got {v}")

    @classmethod
    def noiseless(cls) -> OdometryConfig:
        """Return settings without noise: perfect dead reckoning.

        Returns
        -------
        OdometryConfig
            All densities zero.
        """
        return cls(0.0, 0.0, 0.0)


class Odometry:
    """Integrates noisy increments of the true pose: ``update(true_pose)`` after each step.

    Parameters
    ----------
    config : OdometryConfig
        The noise densities.
    rng : numpy.random.Generator
        Draws the noise.

    Attributes
    ----------
    pose : ndarray of shape (3,)
        The odometry pose ``(x, y, yaw)``.
    """

    def __init__(self, config: OdometryConfig, rng: np.random.Generator):
        self.config = config
        self.rng = rng
        self.pose = np.zeros(3)
        self._last_true = np.zeros(3)

    def reset(self, true_pose) -> np.ndarray:
        """Start the odometry where the robot truly is (the map frame's origin is the start).

        Parameters
        ----------
        true_pose : array-like of shape (3,)
            The robot's true pose ``(x, y, yaw)``.

        Returns
        -------
        ndarray of shape (3,)
            A copy of the odometry pose.
        """
        self._last_true = np.array(true_pose, np.float64)
        self.pose = self._last_true.copy()
        return self.pose.copy()

    def update(self, true_pose) -> np.ndarray:
        """Integrate the noisy increment since the last true pose.

        Parameters
        ----------
        true_pose : array-like of shape (3,)
            The robot's true pose ``(x, y, yaw)`` now.

        Returns
        -------
        ndarray of shape (3,)
            A copy of the odometry pose.
        """
        true_pose = np.asarray(true_pose, np.float64)
        x0, y0, th0 = self._last_true
        c0, s0 = np.cos(th0), np.sin(th0)
        dx, dy = true_pose[0] - x0, true_pose[1] - y0
        fwd, side = c0 * dx + s0 * dy, -s0 * dx + c0 * dy  # increment in the robot frame
        turn = float(wrap_angle(true_pose[2] - th0))
        c = self.config
        dist = abs(fwd) + abs(side)
        n_fwd, n_turn = self.rng.normal(0.0, 1.0, 2)
        fwd += n_fwd * c.translation * np.sqrt(dist)
        turn += n_turn * np.sqrt(
            c.heading_per_metre**2 * dist + c.heading_per_radian**2 * abs(turn)
        )
        x, y, th = self.pose
        # Compose the increment in the odometry's own frame (its errors accumulate); the same
        # frame convention as the measurement, so zero noise reproduces the true pose exactly.
        c_th, s_th = np.cos(th), np.sin(th)
        self.pose = np.array(
            [
                x + fwd * c_th - side * s_th,
                y + fwd * s_th + side * c_th,
                float(wrap_angle(th + turn)),
            ]
        )
        self._last_true = true_pose.copy()
        return self.pose.copy()
