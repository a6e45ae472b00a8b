"""``ManifoldServoConfig``: every setting of the laser + image controller.

The settings of [`ManifoldServo`][servo.laser_image.controller.ManifoldServo], in one frozen
dataclass validated on construction.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from common.validation import check_int

__all__ = ["ManifoldServoConfig"]


@dataclass(frozen=True)
class ManifoldServoConfig:
    """Every setting of [`ManifoldServo`][servo.laser_image.controller.ManifoldServo].

    Checked when made. A frozen dataclass: change a setting with `dataclasses.replace`. The
    defaults are the settings the servo evaluation measures, chosen on the benchmark's ``dev``
    split only.

    Parameters
    ----------
    speed : float, default 1.0
        Cruise speed along the path, m/s.
    lookahead : float, default 1.0
        Distance ahead along the path of the pursued point, m.
    keep_off : float, default 0.4
        Clearance beyond the planning grid's own margin below which the path costs more, m
        (``GeodesicField``'s ``keep_off``), so paths swing wide round corners.
    turn_rate : float, default 1.4
        Angular speed of the observing turn, rad/s.
    image_every : int, default 3
        Steps between the images kept during the observing turn.
    image_weight : float, default 0.3
        Weight of the images against the laser fit in global localisation.
    lost_fit : float, default 0.5
        Share of scan points within 0.1 m of the map below which the scan fits the map badly.
    lost_steps : int, default 10
        Steps of bad fit in a row after which the pose counts as wrong: localise again.
    drift_window : int, default 20
        Steps over which the scan matches' corrections are summed.
    max_drift : float, default 0.6
        Corrections moving the pose more than this within ``drift_window`` steps, beyond what
        odometry said, mean inconsistent tracking (good odometry drifts centimetres there):
        localise again, m.
    arrive_distance : float, default 1.0
        Path left at which the arrival law takes over, m.
    arrive_radius : float, default 0.1
        Distance from the target view's pose (as the map places it) at which the arrival law
        stops driving and turns to the view's heading, m; the map may place a view ~0.3 m off
        and success needs 0.5 m.
    verify_score : float, default 1.4
        The scan's two-way overlap with the target view's (0..2) that confirms arrival.
    max_relocalisations : int, default 3
        Global localisations after which arrival is accepted unverified.
    stuck_steps : int, default 12
        Steps of commanded motion without odometry motion that mean a wall.
    backup_steps : int, default 6
        Steps backed up after a wall is detected.

    Attributes
    ----------
    speed, lookahead, keep_off, ...
        Each parameter, stored under its own name (the object is frozen).

    Examples
    --------
    >>> from dataclasses import replace
    >>> from servo.laser_image import ManifoldServoConfig
    >>> config = ManifoldServoConfig()
    >>> config.speed, config.arrive_radius
    (1.0, 0.1)
    >>> replace(config, speed=0.5).speed
    0.5

    See Also
    --------
    servo.laser_image.ManifoldServo : The controller these settings tune.
    servo.camera_only.SignalServoConfig : The settings of the camera-only controller.
    """

    speed: float = 1.0
    lookahead: float = 1.0
    keep_off: float = 0.4
    turn_rate: float = 1.4
    image_every: int = 3
    image_weight: float = 0.3
    lost_fit: float = 0.5
    lost_steps: int = 10
    drift_window: int = 20
    max_drift: float = 0.6
    arrive_distance: float = 1.0
    arrive_radius: float = 0.1
    verify_score: float = 1.4
    max_relocalisations: int = 3
    stuck_steps: int = 12
    backup_steps: int = 6

    def __post_init__(self):
        """Check every setting's range; raise ``ValueError`` naming the first one out of it."""
        if not 0 < self.speed <= 1.5:
            raise ValueError(f"speed must be in (0, 1.5] m/s, got {self.speed}")
        if not 0 < self.turn_rate <= 1.5:
            raise ValueError(f"turn_rate must be in (0, 1.5] rad/s, got {self.turn_rate}")
        for name in ("lookahead", "arrive_distance", "image_weight", "max_drift"):
            if not getattr(self, name) > 0:
                raise ValueError(f"{name} must be > 0, got {getattr(self, name)}")
        if not (np.isfinite(self.keep_off) and self.keep_off >= 0):
            raise ValueError(f"keep_off must be finite and >= 0 (m), got {self.keep_off}")
        if not 0 < self.arrive_radius < 0.35:
            raise ValueError(f"arrive_radius must be in (0, 0.35) m, got {self.arrive_radius}")
        if not 0 <= self.lost_fit <= 1:
            raise ValueError(f"lost_fit must be in [0, 1], got {self.lost_fit}")
        for name in (
            "image_every",
            "lost_steps",
            "drift_window",
            "max_relocalisations",
            "stuck_steps",
            "backup_steps",
        ):
            check_int(getattr(self, name), name)
