"""The topics a ROS bag import reads and the alignment rule that makes frames of its messages.

`sim.readers.rosbag` reads the bags; `sim.readers.ros_messages` decodes them.

The frame clock is the laser: a scan at stamp ``t`` becomes a frame when an image lies within
``image_tolerance`` of ``t`` (the nearest one is taken) and two consecutive odometry messages
bracket ``t`` at most ``odom_max_gap`` apart (the pose is interpolated linearly between them,
yaw unwrapped; nothing is extrapolated). Of those, a frame is kept when the robot has moved
``min_travel`` or turned ``min_turn`` since the last kept frame (either at 0 keeps every one).
A robot with one of the two sensors: without a camera (``image_topic=None``) every scan with
odometry around it is a candidate frame; without a laser (``scan_topic=None``) the images are
the clock, and every image with odometry around it is a candidate frame.
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

import numpy as np

from common.geometry import se2_compose, wrap_angle
from sim.readers.ros_messages import RosbagImportError, Stream


@dataclass(frozen=True)
class ImportSettings:
    """The topics to read and the alignment rule (see the module docstring).

    Stored in ``meta.json``. Times in seconds, distances in metres, angles in radians.

    Parameters
    ----------
    scan_topic : str or None
        The topic of the ``LaserScan`` messages; None: the robot has no laser, the dataset
        holds images and odometry only.
    image_topic : str or None
        The topic of the ``Image`` (or ``CompressedImage``) messages; None: the robot has no
        camera, the dataset holds scans and odometry only. One of the two must be given.
    odom_topic : str
        The topic of the ``Odometry`` messages.
    world : str, default "robot"
        The name of the place the bags were recorded in (the dataset's world).
    image_tolerance : float, default 0.1
        Largest gap between a scan and the nearest image for a frame, s.
    odom_max_gap : float, default 0.5
        Largest gap between the two odometry messages a scan's pose is interpolated between, s.
    min_travel : float, default 0.1
        Travel since the last kept frame that keeps a frame, m.
    min_turn : float, default 0.2
        Turn since the last kept frame that keeps a frame, rad (either at 0 keeps every one).
    laser_offset : (float, float, float), default (0.0, 0.0, 0.0)
        The laser's pose (x, y, yaw) in the odometry's frame.

    Attributes
    ----------
    scan_topic, image_topic, odom_topic, world, image_tolerance, odom_max_gap, min_travel
        The parameters (the object is frozen).
    min_turn, laser_offset
        The parameters.

    Examples
    --------
    >>> from sim.readers import ImportSettings
    >>> settings = ImportSettings("/scan", "/camera/image", "/odom", min_travel=0.2)
    >>> settings.world, settings.min_travel
    ('robot', 0.2)
    >>> ImportSettings("/scan", "/camera/image", "/odom", image_tolerance=0)
    Traceback (most recent call last):
        ...
    ValueError: image_tolerance must be a number > 0, got 0

    See Also
    --------
    sim.readers.import_rosbags : Imports bags with these settings.
    """

    scan_topic: str | None
    image_topic: str | None
    odom_topic: str
    world: str = "robot"
    image_tolerance: float = 0.1
    odom_max_gap: float = 0.5
    min_travel: float = 0.1
    min_turn: float = 0.2
    laser_offset: tuple[float, float, float] = (0.0, 0.0, 0.0)

    def __post_init__(self):
        """Check the settings; ``ValueError`` names the first that is invalid."""
        optional = {"image_topic": " (or None: no camera)", "scan_topic": " (or None: no laser)"}
        for name in ("scan_topic", "image_topic", "odom_topic", "world"):
            value = getattr(self, name)
            if name in optional and value is None:
                continue
            if not isinstance(value, str) or not value:
                raise ValueError(
                    f"{name} must be a non-empty string{optional.get(name, '')}, got {value!r}"
                )
        if self.scan_topic is None and self.image_topic is None:
            raise ValueError(
                "scan_topic and image_topic are both None: a frame needs a laser scan or a "
                "camera image, so give at least one of the two topics"
            )
        for name in ("image_tolerance", "odom_max_gap"):
            if not (np.isfinite(getattr(self, name)) and getattr(self, name) > 0):
                raise ValueError(f"{name} must be a number > 0, got {getattr(self, name)}")
        for name in ("min_travel", "min_turn"):
            if not (np.isfinite(getattr(self, name)) and getattr(self, name) >= 0):
                raise ValueError(f"{name} must be a number >= 0, got {getattr(self, name)}")
        if len(self.laser_offset) != 3 or not np.all(np.isfinite(self.laser_offset)):
            raise ValueError(f"laser_offset must be 3 finite numbers, got {self.laser_offset}")

    @property
    def laser(self) -> bool:
        """The robot has a laser (``scan_topic`` is given)."""
        return self.scan_topic is not None

    @property
    def camera(self) -> bool:
        """The robot has a camera (``image_topic`` is given)."""
        return self.image_topic is not None


def align(scans: Stream, images: Stream, odom: Stream, settings: ImportSettings):
    """Decide which messages of the frame clock become frames.

    The clock is the scans, or the images without a laser.

    Parameters
    ----------
    scans, images, odom : Stream
        The streams read from the bag (``images`` is replaced by the clock with one sensor).
    settings : ImportSettings
        The alignment rule.

    Returns
    -------
    frames : dict of str to ndarray
        ``"clock"`` (indices of the clock's messages that become frames), ``"odometry"``
        (the laser's interpolated pose, (n, 3)) and ``"commands"`` (velocity, (n, 2)).
    image_index : ndarray of int
        Each frame's image, an index into the image topic.
    dropped : dict of str to int
        How many messages were dropped, by reason.
    """
    clock = scans if settings.laser else images
    t = np.asarray(clock.stamps, dtype=np.int64)
    if not settings.camera or not settings.laser:  # one sensor: each of its messages may be a
        images = Stream(Path("frame clock"), "frame clock")  # frame, its own nearest "image"
        images.stamps = clock.stamps
    t_img = np.asarray(images.stamps, dtype=np.int64)
    t_odo = np.asarray(odom.stamps, dtype=np.int64)
    o = np.asarray(odom.values, dtype=np.float64)
    # nearest image: the neighbours either side in the sorted stamps
    j = np.clip(np.searchsorted(t_img, t), 1, len(t_img) - 1) if len(t_img) > 1 else None
    if j is None:
        nearest = np.zeros(len(t), dtype=int)
    else:
        nearest = np.where(np.abs(t_img[j - 1] - t) <= np.abs(t_img[j] - t), j - 1, j)
    has_image = np.abs(t_img[nearest] - t) <= settings.image_tolerance * 1e9
    # bracketing odometry: messages k-1 and k with t_odo[k-1] <= t <= t_odo[k]
    k = np.clip(np.searchsorted(t_odo, t), 1, len(t_odo) - 1)
    has_odom = (t >= t_odo[0]) & (t <= t_odo[-1])
    has_odom &= (t_odo[k] - t_odo[k - 1]) <= settings.odom_max_gap * 1e9
    dropped = {
        "no image within image_tolerance": int(np.sum(~has_image)),
        "no odometry around the stamp": int(np.sum(has_image & ~has_odom)),
    }
    idx = np.flatnonzero(has_image & has_odom)
    a, b = k[idx] - 1, k[idx]
    w = ((t[idx] - t_odo[a]) / (t_odo[b] - t_odo[a]))[:, None]
    interp = o[a] * (1 - w) + o[b] * w
    yaw = np.unwrap(o[:, 2])
    interp[:, 2] = wrap_angle(yaw[a] * (1 - w[:, 0]) + yaw[b] * w[:, 0])
    pose = se2_compose(interp[:, :3], np.asarray(settings.laser_offset, dtype=np.float64))
    keep = spaced(pose, settings.min_travel, settings.min_turn)
    dropped["closer than min_travel and min_turn"] = int(len(idx) - keep.size)
    if keep.size == 0:
        both = settings.camera and settings.laser
        need = f"an image within {settings.image_tolerance} s and " if both else ""
        what = "scan" if settings.laser else "image"
        raise RosbagImportError(
            f"{clock.where}: no {what} has {need}odometry around it ({dropped}); check the "
            "topics and tolerances"
        )
    frames = {
        "clock": idx[keep],
        "odometry": pose[keep],
        "commands": interp[keep, 3:5],
    }
    return frames, nearest[idx[keep]], dropped


def spaced(pose: np.ndarray, min_travel: float, min_turn: float) -> np.ndarray:
    """Choose the frames kept: the first, then each that moved or turned far enough.

    A frame is kept when it moved ``min_travel`` or turned ``min_turn`` since the last kept
    one (either at 0 keeps every frame).

    Parameters
    ----------
    pose : ndarray of shape (n, 3)
        The frames' poses ``(x, y, yaw)``.
    min_travel : float
        Travel that keeps a frame, m.
    min_turn : float
        Turn that keeps a frame, rad.

    Returns
    -------
    ndarray of int
        Indices of the frames kept.
    """
    keep = [0] if len(pose) else []
    for i in range(1, len(pose)):
        last = pose[keep[-1]]
        moved = np.hypot(*(pose[i, :2] - last[:2]))
        turned = abs(wrap_angle(pose[i, 2] - last[2]))
        if moved >= min_travel or turned >= min_turn:
            keep.append(i)
    return np.asarray(keep, dtype=int)
