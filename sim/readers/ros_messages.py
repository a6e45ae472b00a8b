"""ROS messages to arrays: the per-message half of `sim.readers.rosbag`.

- ``sensor_msgs/LaserScan``: beam ``i`` is at ``angle_min + i * angle_increment`` (spread
  evenly from ``angle_min`` to ``angle_max`` when that is the last beam's angle, since a
  float32 increment drifts over hundreds of beams); readings that are not finite, below
  ``range_min`` or at or beyond ``range_max`` become ``+inf`` (no return), the dataset's
  convention. Range counts one beam off the angles are accepted (drivers differ on whether
  ``angle_max`` is the last beam's angle); more is refused.
- ``sensor_msgs/Image`` (``rgb8``, ``bgr8``, ``rgba8``, ``bgra8``, ``mono8``; rows may be
  padded, ``step``) and ``sensor_msgs/CompressedImage`` (JPEG, PNG: whatever OpenCV decodes):
  RGB uint8, grey repeated in the three channels. An image of more than
  `MAX_IMAGE_PIXELS` pixels is refused, a compressed one by the size its PNG or JPEG
  header states, before it is decoded (a header of a few bytes can claim 40000x40000).
- Message definitions (a bag carries its own) nested more than `MAX_MESSAGE_NESTING`
  types deep, or referring to themselves, are refused before any message is decoded.
- ``nav_msgs/Odometry``: x, y, yaw (from the quaternion, about z), v (twist linear x) and
  omega (twist angular z), all finite (a NaN or infinite value is refused), within
  `common.bounds`, with an orientation quaternion that is not all zeros.

Also here: `Stream`, one topic's messages in stamp order, `damage_errors`, what
a damaged bag raises beneath rosbags (each becomes a
[`RosbagImportError`][sim.readers.ros_messages.RosbagImportError]), `check_bag_path` and
`read_images`, the second pass over the image topic.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from common.bounds import MAX_RANGE, angle_problem, command_problem, pose_problem

ENCODINGS = {"rgb8": (3, None), "bgr8": (3, [2, 1, 0]), "rgba8": (4, None)}
ENCODINGS |= {"bgra8": (4, [2, 1, 0]), "mono8": (1, None)}  # channels, reorder to RGB
SPAN_TOLERANCE = 8 * float(np.finfo(np.float32).eps)  # relative, of a scan's span in beams
# the largest image imported, in pixels: 4096 x 4096, beyond any robot camera the methods take
# (they shrink images to tens of pixels a side), and 50 MB of RGB per frame
MAX_IMAGE_PIXELS = 4096 * 4096
# the deepest nesting of message types in a definition: Odometry is 4 deep (Odometry, its
# PoseWithCovariance, Pose, Point); a definition deeper, or one that refers to itself,
# would exhaust the decoder's recursion
MAX_MESSAGE_NESTING = 32


class RosbagImportError(ValueError):
    """A bag that cannot be imported; the message names the bag, topic and message."""


def stamp_ns(msg) -> int:
    """Return a message's header stamp in nanoseconds.

    Parameters
    ----------
    msg : object
        A ROS message with a ``header``.

    Returns
    -------
    int
        The stamp, ns.
    """
    return int(msg.header.stamp.sec) * 1_000_000_000 + int(msg.header.stamp.nanosec)


def yaw_of(q) -> float:
    """Return the rotation about z (rad) of a quaternion.

    Parameters
    ----------
    q : object
        A quaternion with ``x``, ``y``, ``z``, ``w``.

    Returns
    -------
    float
        The yaw, rad, in ``[-pi, pi]``.
    """
    return float(np.arctan2(2 * (q.w * q.z + q.x * q.y), 1 - 2 * (q.y * q.y + q.z * q.z)))


def odometry_values(msg, where: str) -> tuple[float, float, float, float, float]:
    """Read (x, y, yaw, v, omega) of an odometry message, checked.

    Parameters
    ----------
    msg : object
        A ``nav_msgs/Odometry`` message.
    where : str
        The bag, topic and message index, naming the message in the error if a value, or the
        orientation quaternion, is not finite or out of `common.bounds`.

    Returns
    -------
    tuple of float
        ``(x, y, yaw, v, omega)`` in m, rad, m/s and rad/s.
    """
    p, t = msg.pose.pose, msg.twist.twist
    q = p.orientation
    quaternion = (q.x, q.y, q.z, q.w)
    values = (p.position.x, p.position.y, yaw_of(q), t.linear.x, t.angular.z)
    if not (np.isfinite(quaternion).all() and np.isfinite(values).all()):
        raise RosbagImportError(
            f"{where}: odometry must be finite, got position ({p.position.x}, {p.position.y}), "
            f"orientation {quaternion}, velocity (linear.x {t.linear.x}, angular.z {t.angular.z})"
        )
    if np.hypot.reduce(np.asarray(quaternion, dtype=float)) < 1e-6:  # no rotation at all
        raise RosbagImportError(
            f"{where}: the orientation quaternion is {quaternion}, of length 0; a rotation "
            "has length 1 (identity: x = y = z = 0, w = 1)"
        )
    problem = pose_problem(values[:3], "odometry pose") or command_problem(
        values[3:], "odometry velocity"
    )
    if problem:
        raise RosbagImportError(f"{where}: {problem}")
    return values


def scan_geometry(msg, where: str) -> tuple[int, float, float, float, float]:
    """Read the beam layout of a laser scan message, checked.

    Parameters
    ----------
    msg : object
        A ``sensor_msgs/LaserScan`` message.
    where : str
        The bag, topic and message index, for the error.

    Returns
    -------
    tuple
        ``(beams, angle_min, angle_increment, range_max, angle_max)``.
    """
    n, inc = len(msg.ranges), float(msg.angle_increment)
    if n == 0 or not np.isfinite(inc) or inc == 0:
        raise RosbagImportError(f"{where}: {n} ranges with angle_increment {inc}")
    span = (float(msg.angle_max) - float(msg.angle_min)) / inc + 1
    # drivers differ on whether angle_max is the last beam's angle or one increment beyond;
    # the angles are float32, so the span is exact only to a few float32 epsilons of itself
    # (360 beams with angle_max one increment beyond give 361.000013)
    if abs(span - n) > 1 + SPAN_TOLERANCE * max(abs(span), 1.0):
        raise RosbagImportError(
            f"{where}: {n} ranges, but angle_min {msg.angle_min:.6f}, angle_max "
            f"{msg.angle_max:.6f} and angle_increment {inc:.6f} rad give {span:.1f} beams"
        )
    if not (np.isfinite(msg.range_max) and 0 < msg.range_max <= MAX_RANGE):
        raise RosbagImportError(
            f"{where}: range_max must be in (0, {MAX_RANGE:g}] m, got {msg.range_max}"
        )
    if not (np.isfinite(msg.range_min) and msg.range_min < msg.range_max):
        raise RosbagImportError(
            f"{where}: range_min {msg.range_min} is not below range_max {msg.range_max}, so "
            "every reading would be invalid"
        )
    problem = angle_problem([msg.angle_min, msg.angle_max], "angle_min, angle_max")
    if problem:
        raise RosbagImportError(f"{where}: {problem}")
    return n, float(msg.angle_min), inc, float(msg.range_max), float(msg.angle_max)


def scan_ranges(msg) -> np.ndarray:
    """Return a scan's ranges; not finite, below ``range_min`` or at or beyond ``range_max``: inf.

    Parameters
    ----------
    msg : object
        A ``sensor_msgs/LaserScan`` message.

    Returns
    -------
    ndarray of shape (beams,), float32
        The ranges, m.
    """
    r = np.asarray(msg.ranges, dtype=np.float32).copy()
    ok = np.isfinite(r) & (r >= msg.range_min) & (r < msg.range_max)
    r[~ok] = np.inf
    return r


def decode_image(msg, msgtype: str, where: str) -> np.ndarray:
    """Decode an ``Image`` or ``CompressedImage`` message as an RGB uint8 array (H, W, 3).

    Parameters
    ----------
    msg : object
        The message.
    msgtype : str
        Its type; one ending in ``CompressedImage`` is decoded by OpenCV.
    where : str
        The bag, topic and message index, for the error.

    Returns
    -------
    ndarray of shape (H, W, 3), uint8
        The RGB image.
    """
    import cv2

    data = np.asarray(msg.data, dtype=np.uint8)
    if msgtype.endswith("CompressedImage"):
        size = compressed_size(data.tobytes())
        if size is not None:
            _check_pixels(*size, where)
        try:
            bgr = cv2.imdecode(data, cv2.IMREAD_COLOR) if data.size else None
        except cv2.error:  # a header OpenCV refuses (its own size cap, say)
            bgr = None
        if bgr is None:
            raise RosbagImportError(f"{where}: OpenCV cannot decode it (format {msg.format!r})")
        return np.ascontiguousarray(bgr[..., ::-1])
    if msg.encoding not in ENCODINGS:
        raise RosbagImportError(
            f"{where}: image encoding {msg.encoding!r} is not supported; supported: "
            f"{sorted(ENCODINGS)}"
        )
    channels, order = ENCODINGS[msg.encoding]
    h, w, step = int(msg.height), int(msg.width), int(msg.step)
    _check_pixels(w, h, where)
    if h < 1 or w < 1 or step < w * channels or data.size < step * h:
        raise RosbagImportError(
            f"{where}: {data.size} bytes do not hold a {w}x{h} {msg.encoding} image (step {step})"
        )
    img = data[: step * h].reshape(h, step)[:, : w * channels].reshape(h, w, channels)
    if channels == 1:
        return np.repeat(img, 3, axis=2)
    return np.ascontiguousarray(img[..., order or [0, 1, 2]])


def _check_pixels(width: int, height: int, where: str) -> None:
    if width * height > MAX_IMAGE_PIXELS:
        raise RosbagImportError(
            f"{where}: a {width}x{height} image; at most MAX_IMAGE_PIXELS = {MAX_IMAGE_PIXELS} "
            "pixels are imported"
        )


_JPEG_SOF = {0xC0, 0xC1, 0xC2, 0xC3, 0xC5, 0xC6, 0xC7, 0xC9, 0xCA, 0xCB, 0xCD, 0xCE, 0xCF}


def compressed_size(data: bytes) -> tuple[int, int] | None:
    """Read the (width, height) that a PNG's IHDR or a JPEG's start-of-frame states.

    Read from the header without decoding.

    Parameters
    ----------
    data : bytes
        The compressed image.

    Returns
    -------
    tuple of (int, int) or None
        ``(width, height)``; None for another format or a header too short to say.
    """
    if data[:8] == b"\x89PNG\r\n\x1a\n" and len(data) >= 24 and data[12:16] == b"IHDR":
        return int.from_bytes(data[16:20], "big"), int.from_bytes(data[20:24], "big")
    if data[:2] != b"\xff\xd8":
        return None
    at = 2
    while at + 9 <= len(data) and data[at] == 0xFF:
        marker, length = data[at + 1], int.from_bytes(data[at + 2 : at + 4], "big")
        if marker in _JPEG_SOF:
            height = int.from_bytes(data[at + 5 : at + 7], "big")
            return int.from_bytes(data[at + 7 : at + 9], "big"), height
        at += 2 + length
    return None


def nesting_problem(fielddefs: dict, msgtype: str) -> str | None:
    """Say what is wrong with the definition of ``msgtype`` in a typestore's ``fielddefs``.

    A type that refers to itself, or types nested deeper than `MAX_MESSAGE_NESTING`. Walked
    without recursion past the cap.

    Parameters
    ----------
    fielddefs : dict
        The typestore's definitions by type name.
    msgtype : str
        The message type to check.

    Returns
    -------
    str or None
        The problem, or None.
    """
    depth: dict[str, int] = {}

    def walk(name: str, chain: tuple[str, ...]) -> int:
        if name in chain:
            loop = " -> ".join((*chain[chain.index(name) :], name))
            raise _Nesting(f"message type {name} refers to itself ({loop})")
        if len(chain) >= MAX_MESSAGE_NESTING:
            raise _Nesting(
                f"message type {chain[0]} nests more than MAX_MESSAGE_NESTING = "
                f"{MAX_MESSAGE_NESTING} types deep"
            )
        if name not in depth:
            inner = [walk(sub, (*chain, name)) for sub in _named(fielddefs.get(name))]
            depth[name] = 1 + max(inner, default=0)
        return depth[name]

    try:
        walk(msgtype, ())
    except _Nesting as err:
        return str(err)
    return None


class _Nesting(Exception):
    pass


def _named(definition) -> list[str]:
    """List the message types the fields of ``definition`` (``(constants, fields)``) name.

    Inside arrays and sequences too.
    """
    out = []
    for _, desc in definition[1] if definition else ():
        while int(desc[0]) in (3, 4):  # rosbags' Nodetype ARRAY, SEQUENCE: (element, count)
            desc = desc[1][0]
        if int(desc[0]) == 2:  # Nodetype NAME: another message type
            out.append(desc[1])
    return out


class Stream:
    """One topic's stamps (checked to increase) and per-message values.

    Parameters
    ----------
    bag : Path
        The bag, for the errors.
    topic : str
        The topic, for the errors.

    Attributes
    ----------
    where : str
        The bag's name and the topic.
    stamps : list of int
        The messages' stamps, ns, increasing.
    values : list
        The messages' values.
    """

    def __init__(self, bag: Path, topic: str):
        self.where, self.stamps, self.values = f"{bag.name}: {topic}", [], []

    def add(self, index: int, stamp: int, value) -> None:
        """Append a message; a stamp not after the previous one raises `RosbagImportError`.

        Parameters
        ----------
        index : int
            The message's index in the topic, for the error.
        stamp : int
            Its stamp, ns.
        value : object
            Its value.
        """
        if self.stamps and stamp == self.stamps[-1]:
            raise RosbagImportError(
                f"{self.where} message {index}: the same stamp {stamp / 1e9:.9f} s as the "
                "previous message; two messages of one topic cannot share a stamp. If the bag "
                "was written from a log with few digits (stamps rounded to microseconds or "
                "coarser), write it again with full nanosecond stamps, or leave out the "
                "repeated messages (e.g. `rosbag filter` / `ros2 bag convert`)"
            )
        if self.stamps and stamp < self.stamps[-1]:
            raise RosbagImportError(
                f"{self.where} message {index}: stamp {stamp / 1e9:.9f} s is not after the "
                f"previous message's {self.stamps[-1] / 1e9:.9f} s (timestamps out of order)"
            )
        self.stamps.append(stamp)
        self.values.append(value)


def damage_errors() -> tuple[type[BaseException], ...]:
    """List what rosbags and the libraries under it raise on a damaged bag.

    Its readers' own errors, SQLite's (ROS 2 ``.db3``), and the plain errors of a truncated
    record, a corrupt index or a message definition whose type names are damaged.

    Returns
    -------
    tuple of type
        The exception classes.
    """
    import sqlite3
    import struct
    import zlib

    from rosbags.rosbag1 import ReaderError as Ros1Error
    from rosbags.rosbag2 import ReaderError as Ros2Error

    errors = [Ros1Error, Ros2Error, sqlite3.Error, OSError, EOFError, struct.error, zlib.error]
    # a definition deeper than nesting_problem's walk sees (a type not among the topics read)
    errors += [RecursionError]
    errors += [KeyError, IndexError, ValueError, AssertionError, TypeError, AttributeError]
    try:
        import apsw  # rosbags' SQLite binding, where installed
    except ImportError:
        pass
    else:
        errors.append(apsw.Error)
    return tuple(errors)


def check_bag_path(bag: Path) -> None:
    """Refuse a path that is no bag with a `RosbagImportError`.

    No bag: missing, a named pipe or a device (or a directory holding one), or a directory
    without a ROS 2 bag's ``metadata.yaml`` (an empty directory, say).

    Parameters
    ----------
    bag : Path
        The ROS 1 ``.bag`` file or ROS 2 bag directory.
    """
    if not bag.exists():
        raise RosbagImportError(f"{bag}: no such bag (a ROS 1 .bag file or a ROS 2 bag directory)")
    # a named pipe or a device (or a link to one) would block the reader or never end
    special = [
        p
        for p in (bag, *(bag.iterdir() if bag.is_dir() else ()))
        if not (p.is_file() or p.is_dir())
    ]
    if special:
        raise RosbagImportError(
            f"{special[0]}: neither a regular file nor a directory (a named pipe, a device, or "
            "a link to one); a bag is a ROS 1 .bag file or a ROS 2 bag directory of files"
        )
    if bag.is_dir() and not (bag / "metadata.yaml").is_file():
        raise RosbagImportError(
            f"{bag}: a directory without metadata.yaml, so not a ROS 2 bag (a ROS 1 bag is a "
            ".bag file)"
        )
    if bag.is_file() and bag.suffix != ".bag":
        with open(bag, "rb") as f:
            ros1 = f.read(13) == b"#ROSBAG V2.0\n"
        raise RosbagImportError(
            f"{bag}: "
            + ("a ROS 1 bag, but" if ros1 else "a file, so not a ROS 2 bag (a directory), and")
            + " without the .bag suffix, by which the reader knows a ROS 1 bag: rename it to "
            f"{bag.name}.bag (or link it under that name)"
        )


def read_images(reader, conns, image_index: np.ndarray, bag: Path, settings) -> np.ndarray:
    """Decode the images the frames use (a second pass over the image topic only).

    Parameters
    ----------
    reader : rosbags.highlevel.AnyReader
        The open bag.
    conns : list
        The image topic's connections.
    image_index : ndarray of int
        Each frame's image, an index into the image topic.
    bag : Path
        The bag, for the errors.
    settings : ImportSettings
        The import's settings (its ``image_topic``).

    Returns
    -------
    ndarray of shape (n, H, W, 3), uint8
        The frames' images.
    """
    needed = set(image_index.tolist())
    decoded, shape = {}, None
    for i, (conn, _, raw) in enumerate(reader.messages(connections=conns)):
        if i not in needed:
            continue
        where = f"{bag.name}: {settings.image_topic} message {i}"
        img = decode_image(reader.deserialize(raw, conn.msgtype), conn.msgtype, where)
        if shape is None:
            shape = img.shape
        elif img.shape != shape:
            raise RosbagImportError(
                f"{where}: image is {img.shape[1]}x{img.shape[0]}, the earlier ones "
                f"{shape[1]}x{shape[0]} (images of changing size)"
            )
        decoded[i] = img
    return np.stack([decoded[i] for i in image_index.tolist()])
