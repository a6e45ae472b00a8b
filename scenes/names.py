"""Every name shared between the scene builders, the simulator and the tools.

One module of names (as MuJoCo Menagerie's ``*_constants.py``) so that no string literal is
repeated across layers.
"""

HALLWAY = "hallway"
LAWN = "lawn"
WORLDS = (HALLWAY, LAWN)

BRANCHES = ("left", "straight", "right")


def manifold_name(world: str, branch: str | None = None) -> str:
    """Return the name of a ground-truth manifold: ``"hallway"``, ``"hallway-left"`` and so on.

    Parameters
    ----------
    world : str
        The world's name.
    branch : str or None, default None
        The branch; None: the world's main manifold.

    Returns
    -------
    str
        ``world``, or ``world-branch``.
    """
    return world if branch is None else f"{world}-{branch}"


# The paper's 8 manifolds, in the order of its Figure 7 rows (this order defines label ids).
MANIFOLDS = tuple(
    name for world in WORLDS for name in (world, *(manifold_name(world, b) for b in BRANCHES))
)
MANIFOLD_IDS = {name: i for i, name in enumerate(MANIFOLDS)}
NO_MANIFOLD = -1  # label id of a point on no manifold (inside a wall, off the property)

# Robot model.
ROBOT_BODY = "robot"
ROBOT_JOINT_X = "robot_x"
ROBOT_JOINT_Y = "robot_y"
ROBOT_JOINT_YAW = "robot_yaw"
ROBOT_ACT_X = "robot_vx"
ROBOT_ACT_Y = "robot_vy"
ROBOT_ACT_YAW = "robot_wz"
ROBOT_CHASSIS = "robot_chassis"
ROBOT_CAMERA = "robot_camera"
LASER_SITE = "laser"
CHASE_CAMERA = "chase_camera"
TOP_CAMERA = "top_camera"

# Geom groups: what renders and what the laser sees (as Menagerie separates visual/collision).
GROUP_SOLID = 0  # visible and collides (walls, furniture, trunks): the laser sees it
GROUP_DECOR = 1  # visible only (floor, posters, canopies): the laser ignores it
GROUP_ROBOT = 2  # the robot itself: never in its own laser
GROUP_COLLIDER = 3  # invisible collision proxy (under a hedge mesh): the laser sees it
LASER_GEOMGROUP = (1, 0, 0, 1, 0, 0)  # groups the laser ray-casts against
