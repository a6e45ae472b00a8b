"""The physics of one world with the robot in it: unicycle control, sensors, odometry.

``Simulator`` is what the env, the teleop collector and the servo share: it turns a command
``(v, omega)`` into velocity-actuator targets, steps MuJoCo, and reads the camera, the laser and
the odometry. It knows nothing of rewards or episodes.
"""

from __future__ import annotations

import mujoco
import numpy as np

from common.geometry import wrap_angle
from scenes import World, names
from sim.camera import Camera, CameraConfig
from sim.laser import Laser, LaserConfig
from sim.odometry import Odometry, OdometryConfig

CONTROL_DT = 0.1  # s per command: 10 Hz, a typical base controller rate
V_LIMITS = (-0.5, 1.5)  # m/s: backing up slowly, walking pace forward
OMEGA_LIMIT = 1.5  # rad/s


def compile_world(world: World) -> mujoco.MjModel:
    """Compile the MuJoCo model of a world (textures come from ``world.assets``).

    Parameters
    ----------
    world : scenes.World
        The world's MJCF and assets.

    Returns
    -------
    mujoco.MjModel
        The compiled model.
    """
    return mujoco.MjModel.from_xml_string(world.xml, world.assets)


class Simulator:
    """One robot in one world: MuJoCo physics, the camera, the laser and odometry.

    The robot is a unicycle on slide and hinge joints with velocity actuators; the camera
    renders off-screen (EGL, OSMesa as fallback; the renderer opens on first use) and the laser
    casts all its beams in one ``mj_multiRay``.

    Parameters
    ----------
    world : scenes.World
        The world to compile.
    camera : CameraConfig or None, default None
        The camera; None: no camera (laser-only runs never create a GL context).
    laser : LaserConfig or None, default None
        The laser; None: no laser.
    odometry : OdometryConfig or None, default None
        The odometry's drift; None: ``OdometryConfig()``.
    control_dt : float, default 0.1
        Seconds each [`step`][sim.simulator.Simulator.step] command is held (rounded to whole
        physics steps).

    Attributes
    ----------
    world : scenes.World
        The world.
    model, data : mujoco.MjModel, mujoco.MjData
        The compiled model and its state.
    control_dt : float
        The hold time actually used, s.
    camera, laser, odometry
        The sensors (None where not given).
    collisions : int
        Steps in contact since the last [`reset`][sim.simulator.Simulator.reset].
    pose : ndarray of shape (3,)
        The true pose (x, y, yaw).

    Examples
    --------
    >>> import numpy as np
    >>> import sim  # headless rendering, chosen before anything imports mujoco
    >>> from scenes import build_world
    >>> from sim.laser import LaserConfig
    >>> from sim.simulator import Simulator
    >>> robot = Simulator(build_world("lawn"), laser=LaserConfig())
    >>> robot.reset([8.0, 2.0, 0.0], np.random.default_rng(0))
    >>> for _ in range(10):
    ...     touched = robot.step(1.0, 0.0)  # 1 m/s straight ahead for 1 s
    >>> robot.pose.round(1).tolist(), robot.scan().shape
    ([9.0, 2.0, 0.0], (361,))
    >>> robot.close()

    See Also
    --------
    sim.env.NavigationEnv : The Gymnasium env around a simulator.
    sim.collect.collect_dataset : Recordings of scripted drives.
    """

    def __init__(
        self,
        world: World,
        camera: CameraConfig | None = None,
        laser: LaserConfig | None = None,
        odometry: OdometryConfig | None = None,
        control_dt: float = CONTROL_DT,
    ):
        if not (np.isfinite(control_dt) and control_dt > 0):
            raise ValueError(f"control_dt must be > 0 seconds, got {control_dt}")
        self.world = world
        self.model = compile_world(world)
        self.data = mujoco.MjData(self.model)
        self.n_substeps = max(1, round(control_dt / self.model.opt.timestep))
        self.control_dt = self.n_substeps * self.model.opt.timestep
        self.camera = Camera(self.model, camera) if camera is not None else None
        self.laser = Laser(self.model, laser) if laser is not None else None
        self.odometry = Odometry(odometry or OdometryConfig(), np.random.default_rng(0))
        j = [
            mujoco.mj_name2id(self.model, mujoco.mjtObj.mjOBJ_JOINT, n)
            for n in (names.ROBOT_JOINT_X, names.ROBOT_JOINT_Y, names.ROBOT_JOINT_YAW)
        ]
        self._qpos = np.array([self.model.jnt_qposadr[i] for i in j])
        self._qvel = np.array([self.model.jnt_dofadr[i] for i in j])
        a = [
            mujoco.mj_name2id(self.model, mujoco.mjtObj.mjOBJ_ACTUATOR, n)
            for n in (names.ROBOT_ACT_X, names.ROBOT_ACT_Y, names.ROBOT_ACT_YAW)
        ]
        self._act = np.array(a)
        self.chassis = mujoco.mj_name2id(self.model, mujoco.mjtObj.mjOBJ_GEOM, names.ROBOT_CHASSIS)
        self.collisions = 0

    # -- state ------------------------------------------------------------------------------
    @property
    def pose(self) -> np.ndarray:
        """True pose ``(x, y, yaw)`` in the world frame (yaw wrapped to [-pi, pi))."""
        x, y, yaw = self.data.qpos[self._qpos]
        return np.array([x, y, float(wrap_angle(yaw))])

    @property
    def time(self) -> float:
        """Simulated time since the last reset, s."""
        return float(self.data.time)

    def reset(self, pose, rng: np.random.Generator) -> None:
        """Place the robot at rest at ``pose`` and restart odometry; ``rng`` drives the noise.

        Parameters
        ----------
        pose : array-like of shape (3,)
            Finite ``(x, y, yaw)`` in the world frame.
        rng : numpy.random.Generator
            Drives the odometry's noise.
        """
        pose = np.asarray(pose, np.float64)
        if pose.shape != (3,) or not np.all(np.isfinite(pose)):
            raise ValueError(f"pose must be a finite (x, y, yaw), got {pose!r}")
        mujoco.mj_resetData(self.model, self.data)
        self.data.qpos[self._qpos] = pose
        mujoco.mj_forward(self.model, self.data)
        self.odometry.rng = rng
        self.odometry.reset(self.pose)
        self.collisions = 0

    def in_contact(self) -> bool:
        """Check whether the chassis touches anything now.

        Returns
        -------
        bool
            True while the chassis is in contact.
        """
        n = self.data.ncon
        return bool(n and np.any(self.data.contact.geom[:n] == self.chassis))

    # -- acting -----------------------------------------------------------------------------
    def step(self, v: float, omega: float) -> bool:
        """Hold the command for ``control_dt``; return whether the chassis touched anything.

        The base is a unicycle: each substep turns ``(v, omega)`` into world-frame velocity
        targets using the heading at the middle of the substep.

        Parameters
        ----------
        v : float
            Forward speed, m/s, clipped to ``V_LIMITS``.
        omega : float
            Turn rate, rad/s, clipped to ``[-OMEGA_LIMIT, OMEGA_LIMIT]``.

        Returns
        -------
        bool
            Whether the chassis touched anything during the step.
        """
        v = float(np.clip(v, *V_LIMITS))
        omega = float(np.clip(omega, -OMEGA_LIMIT, OMEGA_LIMIT))
        d, dt = self.data, self.model.opt.timestep
        touched = False
        for _ in range(self.n_substeps):
            yaw = d.qpos[self._qpos[2]] + 0.5 * omega * dt
            d.ctrl[self._act] = (v * np.cos(yaw), v * np.sin(yaw), omega)
            mujoco.mj_step(self.model, d)
            touched = touched or self.in_contact()
        # mj_step leaves positions-derived quantities one step stale: refresh for sensors.
        mujoco.mj_forward(self.model, d)
        self.collisions += int(touched)
        self.odometry.update(self.pose)
        return touched

    # -- sensing ----------------------------------------------------------------------------
    def render(self) -> np.ndarray:
        """Render the camera image; ``RuntimeError`` without a camera.

        Returns
        -------
        ndarray of shape (H, W, 3), uint8
            The RGB image.
        """
        if self.camera is None:
            raise RuntimeError("this Simulator has no camera (camera=None)")
        return self.camera.render(self.data)

    def scan(self, rng: np.random.Generator | None = None) -> np.ndarray:
        """Cast the laser; the ranges are noisy when ``rng`` is given.

        ``RuntimeError`` without a laser.

        Parameters
        ----------
        rng : numpy.random.Generator, optional
            Drives the range noise; None: noise-free ranges.

        Returns
        -------
        ndarray of shape (beams,), float32
            The ranges, m; +inf: no return.
        """
        if self.laser is None:
            raise RuntimeError("this Simulator has no laser (laser=None)")
        return self.laser.scan(self.data, rng)

    def close(self) -> None:
        """Free renderers; safe to call twice."""
        if self.camera is not None:
            self.camera.close()
