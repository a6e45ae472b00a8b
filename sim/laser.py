"""A 2-D laser range finder ray-cast with one ``mujoco.mj_multiRay`` call per scan.

Beams with no return within ``max_range`` are reported as ``+inf`` (the ROS REP 117
convention), never as a fake range. Noise is Gaussian on the range of beams that hit.
"""

from __future__ import annotations

from dataclasses import dataclass

import mujoco
import numpy as np

from scenes import names

# Real 2-D lasers have a few hundred to a few thousand beams (SICK LMS-200: 361, Hokuyo
# UTM-30LX: 1081); 100 000 is far beyond them and still casts a scan in well under a second,
# where a count of 10^8 would hang the collection allocating and casting rays.
MAX_BEAMS = 100_000


@dataclass(frozen=True)
class LaserConfig:
    """Field of view, beam count, max range and range noise of the laser.

    Defaults: a SICK LMS-200-like 180 deg, 0.5 deg beams.

    Parameters
    ----------
    fov : float, default pi
        Field of view, rad, centred on the robot's heading, in (0, 2 pi].
    beams : int, default 361
        Beam count, in ``[1, MAX_BEAMS]``.
    max_range : float, default 20.0
        Maximum range, m.
    noise_std : float, default 0.01
        Range noise standard deviation, m.
    """

    fov: float = np.pi
    beams: int = 361
    max_range: float = 20.0
    noise_std: float = 0.01

    def __post_init__(self):
        """Check the settings; ``ValueError`` names the first that is invalid."""
        if not (0 < self.fov <= 2 * np.pi):
            raise ValueError(f"laser fov must be in (0, 2*pi] radians, got {self.fov}")
        if int(self.beams) != self.beams or not (1 <= self.beams <= MAX_BEAMS):
            raise ValueError(
                f"laser beams must be an integer in [1, {MAX_BEAMS}], got {self.beams}"
            )
        if not (np.isfinite(self.max_range) and self.max_range > 0):
            raise ValueError(f"laser max_range must be a finite number > 0, got {self.max_range}")
        if not (np.isfinite(self.noise_std) and self.noise_std >= 0):
            raise ValueError(f"laser noise_std must be >= 0, got {self.noise_std}")

    @property
    def angles(self) -> np.ndarray:
        """Beam angles (rad) in the sensor frame, counter-clockwise from -fov/2."""
        if self.beams == 1:
            return np.zeros(1)
        full_circle = np.isclose(self.fov, 2 * np.pi)
        n = self.beams if full_circle else self.beams - 1
        return -self.fov / 2 + self.fov * np.arange(self.beams) / n


class Laser:
    """Ray-caster bound to one model; excludes the robot's own geoms (group and body).

    Parameters
    ----------
    model : mujoco.MjModel
        The model.
    config : LaserConfig
        The laser's settings.
    """

    def __init__(self, model: mujoco.MjModel, config: LaserConfig):
        self.model = model
        self.config = config
        self.site_id = mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_SITE, names.LASER_SITE)
        self.robot_body = mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_BODY, names.ROBOT_BODY)
        self._angles = config.angles
        self._geomgroup = np.array(names.LASER_GEOMGROUP, np.uint8)
        self._geomid = np.zeros(config.beams, np.int32)
        self._dist = np.zeros(config.beams, np.float64)
        self._vec = np.zeros(3 * config.beams, np.float64)

    def origin_and_heading(self, data: mujoco.MjData) -> tuple[np.ndarray, float]:
        """Return the laser site's position and heading.

        Parameters
        ----------
        data : mujoco.MjData
            The model's state.

        Returns
        -------
        origin : ndarray of shape (3,)
            The site's position in the world frame.
        heading : float
            Its yaw, rad.
        """
        xmat = data.site_xmat[self.site_id].reshape(3, 3)
        return data.site_xpos[self.site_id].copy(), float(np.arctan2(xmat[1, 0], xmat[0, 0]))

    def scan(self, data: mujoco.MjData, rng: np.random.Generator | None = None) -> np.ndarray:
        """Cast the beams from the current state.

        Requires positions to be fresh (``mj_forward`` or ``mj_kinematics`` after the last
        ``mj_step``).

        Parameters
        ----------
        data : mujoco.MjData
            The model's state.
        rng : numpy.random.Generator, optional
            Draws the range noise; None: noise-free.

        Returns
        -------
        ndarray of shape (beams,), float32
            The ranges, m; +inf: no return within ``max_range``.
        """
        origin, heading = self.origin_and_heading(data)
        a = self._angles + heading
        vec = self._vec.reshape(-1, 3)
        vec[:, 0] = np.cos(a)
        vec[:, 1] = np.sin(a)
        mujoco.mj_multiRay(
            self.model,
            data,
            origin,
            self._vec,
            self._geomgroup,
            1,
            self.robot_body,
            self._geomid,
            self._dist,
            None,
            self.config.beams,
            self.config.max_range,
        )
        ranges = self._dist.copy()
        hit = (self._geomid >= 0) & (ranges >= 0) & (ranges <= self.config.max_range)
        if rng is not None and self.config.noise_std > 0:
            ranges[hit] += rng.normal(0.0, self.config.noise_std, int(hit.sum()))
            np.maximum(ranges, 0.0, out=ranges)
        ranges[~hit] = np.inf
        return ranges.astype(np.float32)
