"""The robot: a planar differential-drive base with a camera mast and a laser site.

The base's joints are slide x, slide y and hinge yaw. This module holds only the robot; the world
builders add it to their scene.

A planar joint chain with velocity actuators ran at 80-90k steps/s with wall contacts and never
passed through a wall at 2 m/s in our measurements, where a free-joint two-wheel robot was 2-3x
slower and slipped; see ../shared/notes/mujoco-on-cpu.md.
"""

from __future__ import annotations

import xml.etree.ElementTree as ET

from scenes import names
from scenes.mjcf import SceneBuilder, fmt

RADIUS = 0.22  # m, chassis (a Pioneer-sized base)
CHASSIS_HEIGHT = 0.30  # m
CHASSIS_CLEARANCE = 0.05  # m above the floor
MASS = 20.0  # kg
CAMERA_HEIGHT = 1.0  # m, roughly a hand-held camera
CAMERA_FORWARD = 0.12  # m ahead of the axle
CAMERA_FOVY = 45.0  # degrees (vertical)
LASER_HEIGHT = 0.30  # m: below table tops, above skirting
LASER_FORWARD = 0.15  # m
# Velocity servo gains: time constants of ~0.05 s (linear) and ~0.01 s (yaw). The force limits
# must not be reached in normal driving: implicitfast integrates the kv damping implicitly, and
# a clamped force breaks that and makes the velocity oscillate bang-bang between steps.
VELOCITY_GAIN = 400.0  # N s/m
YAW_GAIN = 50.0  # N m s/rad
MAX_FORCE = 800.0  # N: saturates only for speed errors over 2 m/s, e.g. pushing a wall
MAX_TORQUE = 150.0  # N m: saturates only for turn-rate errors over 3 rad/s


def add_robot(scene: SceneBuilder) -> ET.Element:
    """Append the robot body, its joints, sensors' frames and actuators to ``scene``.

    The body sits at the world origin so that its joint positions *are* the world pose
    ``(x, y, yaw)``; the simulator places it by writing ``qpos``.

    Parameters
    ----------
    scene : SceneBuilder
        The world's scene.

    Returns
    -------
    xml.etree.ElementTree.Element
        The robot's ``<body>`` element.
    """
    body = ET.SubElement(scene.worldbody, "body", name=names.ROBOT_BODY, pos="0 0 0")
    ET.SubElement(body, "inertial", pos="0 0 0.2", mass=fmt(MASS), diaginertia="0.6 0.6 0.5")
    ET.SubElement(body, "joint", name=names.ROBOT_JOINT_X, type="slide", axis="1 0 0", damping="0")
    ET.SubElement(body, "joint", name=names.ROBOT_JOINT_Y, type="slide", axis="0 1 0", damping="0")
    ET.SubElement(body, "joint", name=names.ROBOT_JOINT_YAW, type="hinge", axis="0 0 1")
    half = CHASSIS_HEIGHT / 2.0
    ET.SubElement(
        body,
        "geom",
        name=names.ROBOT_CHASSIS,
        type="cylinder",
        size=fmt((RADIUS, half)),
        pos=fmt((0, 0, CHASSIS_CLEARANCE + half)),
        rgba="0.15 0.15 0.18 1",
        group=str(names.GROUP_ROBOT),
        friction="0.2 0.005 0.0001",
    )
    ET.SubElement(
        body,
        "geom",
        name="robot_mast",
        type="cylinder",
        size=fmt((0.025, (CAMERA_HEIGHT - CHASSIS_HEIGHT) / 2)),
        pos=fmt((0, 0, (CAMERA_HEIGHT + CHASSIS_HEIGHT) / 2)),
        rgba="0.6 0.6 0.6 1",
        group=str(names.GROUP_ROBOT),
        contype="0",
        conaffinity="0",
    )
    ET.SubElement(
        body,
        "geom",
        name="robot_nose",
        type="box",
        size="0.05 0.08 0.02",
        pos=fmt((RADIUS - 0.04, 0, CHASSIS_CLEARANCE + CHASSIS_HEIGHT + 0.02)),
        rgba="0.9 0.5 0.1 1",
        group=str(names.GROUP_ROBOT),
        contype="0",
        conaffinity="0",
    )
    # Camera looks along the body's +x: camera -z = +x, camera y = +z.
    ET.SubElement(
        body,
        "camera",
        name=names.ROBOT_CAMERA,
        pos=fmt((CAMERA_FORWARD, 0, CAMERA_HEIGHT)),
        xyaxes="0 -1 0 0 0 1",
        fovy=fmt(CAMERA_FOVY),
    )
    ET.SubElement(
        body,
        "camera",
        name=names.CHASE_CAMERA,
        pos="-2.6 0 2.0",
        xyaxes="0 -1 0 0.45 0 0.89",
        fovy="60",
    )
    ET.SubElement(
        body, "site", name=names.LASER_SITE, pos=fmt((LASER_FORWARD, 0, LASER_HEIGHT)), size="0.03"
    )
    for act, joint, gain, limit in (
        (names.ROBOT_ACT_X, names.ROBOT_JOINT_X, VELOCITY_GAIN, MAX_FORCE),
        (names.ROBOT_ACT_Y, names.ROBOT_JOINT_Y, VELOCITY_GAIN, MAX_FORCE),
        (names.ROBOT_ACT_YAW, names.ROBOT_JOINT_YAW, YAW_GAIN, MAX_TORQUE),
    ):
        ET.SubElement(
            scene.actuator,
            "velocity",
            name=act,
            joint=joint,
            kv=fmt(gain),
            forcerange=fmt((-limit, limit)),
        )
    return body
