"""Wheel odometry: the true motion between two poses, corrupted by noise and integrated.

The noise follows the standard odometry motion model (Thrun, Burgard & Fox, *Probabilistic
Robotics*, sec. 5.4): each increment is split into rotation-translation-rotation, and each part
gets zero-mean Gaussian noise whose variance grows with the motion.
"""

from __future__ import annotations

from dataclasses import asdict, dataclass

import numpy as np


def wrap_angle(a):
    """Angles wrapped to [-pi, pi)."""
    return (np.asarray(a) + np.pi) % (2.0 * np.pi) - np.pi


@dataclass(frozen=True)
class OdometryConfig:
    """Noise of the odometry motion model; all zero gives perfect dead reckoning.

    alpha1 : rotation noise per rotation (rad/rad); alpha2 : rotation noise per metre;
    alpha3 : translation noise per metre (m/m); alpha4 : translation noise per radian.
    """

    alpha1: float = 0.02
    alpha2: float = 0.01
    alpha3: float = 0.02
    alpha4: float = 0.005

    def __post_init__(self):
        for k, v in asdict(self).items():
            if not np.isfinite(v) or v < 0:
                raise ValueError(f"odometry {k} must be a finite number >= 0, got {v}")

    @classmethod
    def noiseless(cls) -> OdometryConfig:
        return cls(0.0, 0.0, 0.0, 0.0)


class Odometry:
    """Integrates noisy increments of the true pose: ``update(true_pose)`` after each step."""

    def __init__(self, config: OdometryConfig, rng: np.random.Generator):
        self.config = config
        self.rng = rng
        self.pose = np.zeros(3)
        self._last_true = np.zeros(3)

    def reset(self, true_pose) -> np.ndarray:
        """Odometry starts where the robot truly is (the map frame's origin is the start)."""
        self._last_true = np.array(true_pose, np.float64)
        self.pose = self._last_true.copy()
        return self.pose.copy()

    def update(self, true_pose) -> np.ndarray:
        true_pose = np.asarray(true_pose, np.float64)
        dx, dy = true_pose[:2] - self._last_true[:2]
        trans = float(np.hypot(dx, dy))
        rot1 = float(wrap_angle(np.arctan2(dy, dx) - self._last_true[2])) if trans > 1e-9 else 0.0
        if abs(rot1) > np.pi / 2:  # driving backwards: model it as a negative translation
            rot1 = float(wrap_angle(rot1 - np.pi))
            trans = -trans
        rot2 = float(wrap_angle(true_pose[2] - self._last_true[2] - rot1))
        c = self.config
        sd = np.sqrt(
            [
                c.alpha1 * rot1**2 + c.alpha2 * trans**2,
                c.alpha3 * trans**2 + c.alpha4 * (rot1**2 + rot2**2),
                c.alpha1 * rot2**2 + c.alpha2 * trans**2,
            ]
        )
        n1, nt, n2 = self.rng.normal(0.0, 1.0, 3) * sd
        rot1, trans, rot2 = rot1 + n1, trans + nt, rot2 + n2
        x, y, th = self.pose
        self.pose = np.array(
            [
                x + trans * np.cos(th + rot1),
                y + trans * np.sin(th + rot1),
                float(wrap_angle(th + rot1 + rot2)),
            ]
        )
        self._last_true = true_pose.copy()
        return self.pose.copy()
