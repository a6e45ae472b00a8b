"""Simulation: physics, sensors, scripted teleop, datasets and the plain navigation envs.

Physics, the robot's camera, laser and odometry, scripted teleop, datasets, and the plain
navigation envs ``topomap/Hallway-v0`` and ``topomap/Lawn-v0``.

Importing ``sim`` chooses the headless GL backend (``MUJOCO_GL=egl``, OSMesa as fallback)
before MuJoCo is loaded, and registers the envs with string entry points.
"""

from sim._gl import BACKEND  # noqa: F401  (must run before anything imports mujoco)
from sim.registration import register_envs

register_envs()
