"""Write small ROS 1 and ROS 2 bags with rosbags' own writers, for the import tests."""

from __future__ import annotations

from dataclasses import dataclass, field
from pathlib import Path

import cv2
import numpy as np
from rosbags.rosbag1 import Writer as Writer1
from rosbags.rosbag2 import StoragePlugin
from rosbags.rosbag2 import Writer as Writer2
from rosbags.typesys import Stores, get_typestore

SCAN, IMAGE, ODOM = "/scan", "/camera/image", "/odom"


@dataclass
class Drive:
    """What a bag holds: scans (N, B) at ``t_scan``, RGB images at ``t_image``, odometry
    poses (M, 3) and velocities (M, 2) at ``t_odom``; times in seconds."""

    t_scan: np.ndarray
    ranges: np.ndarray
    angles: np.ndarray
    t_image: np.ndarray
    images: np.ndarray
    t_odom: np.ndarray
    poses: np.ndarray
    velocities: np.ndarray
    range_max: float = 20.0
    start_ns: int = 1_700_000_000 * 10**9  # a plausible epoch stamp
    increment: float | None = None  # the scans' angle_increment (None: from the angles)
    scan_log_times: np.ndarray | None = None  # when scans are logged (None: at their stamps)
    extra: list = field(default_factory=list)  # (topic, [(t, make(ts, ros1, ns))]) as well


def drive_from_sequence(seq, max_range: float, odom_step: float = 0.2) -> Drive:
    """A bag's streams from a simulated sequence: scans at its frame times, images 10 ms
    later, odometry at the frame times and every ``odom_step`` s between (linear between)."""
    t = seq.times - seq.times[0] + 0.5
    grid = np.arange(t[0], t[-1], odom_step)
    far = np.abs(grid[:, None] - t[None, :]).min(axis=1) > 1e-3  # distinct stamps in ns
    t_odom = np.union1d(t, grid[far])
    yaw = np.unwrap(seq.odometry[:, 2])
    poses = np.column_stack([np.interp(t_odom, t, c) for c in (*seq.odometry[:, :2].T, yaw)])
    poses[:, 2] = (poses[:, 2] + np.pi) % (2 * np.pi) - np.pi
    vel = np.column_stack([np.interp(t_odom, t, c) for c in seq.commands.T])
    return Drive(t, seq.scans, seq.angles, t + 0.01, seq.images, t_odom, poses, vel, max_range)


def _time(ts, ns: int):
    return ts.types["builtin_interfaces/msg/Time"](sec=ns // 10**9, nanosec=ns % 10**9)


def _header(ts, ros1: bool, ns: int, frame: str):
    header = ts.types["std_msgs/msg/Header"]
    extra = {"seq": 0} if ros1 else {}
    return header(stamp=_time(ts, ns), frame_id=frame, **extra)


def scan_msg(ts, ros1, ns, ranges, angles, range_max=20.0, increment=None):
    inc = float(angles[1] - angles[0]) if increment is None else increment
    return ts.types["sensor_msgs/msg/LaserScan"](
        header=_header(ts, ros1, ns, "laser"),
        angle_min=float(angles[0]),
        angle_max=float(angles[-1]),
        angle_increment=inc,
        time_increment=0.0,
        scan_time=0.1,
        range_min=0.05,
        range_max=float(range_max),
        ranges=np.where(np.isfinite(ranges), ranges, np.inf).astype(np.float32),
        intensities=np.zeros(0, np.float32),
    )


def image_msg(ts, ros1, ns, rgb, encoding="rgb8"):
    """A ``sensor_msgs/Image`` (``encoding`` rgb8, bgr8 or mono8) or, for "png" / "jpeg", a
    ``sensor_msgs/CompressedImage``."""
    header = _header(ts, ros1, ns, "camera")
    if encoding in ("png", "jpeg"):
        ok, buf = cv2.imencode(f".{'jpg' if encoding == 'jpeg' else 'png'}", rgb[..., ::-1])
        assert ok
        cls = ts.types["sensor_msgs/msg/CompressedImage"]
        return cls(header=header, format=encoding, data=buf.ravel())
    pixels = {"rgb8": rgb, "bgr8": rgb[..., ::-1], "mono8": rgb[..., :1]}[encoding]
    h, w, c = pixels.shape
    return ts.types["sensor_msgs/msg/Image"](
        header=header,
        height=h,
        width=w,
        encoding=encoding,
        is_bigendian=0,
        step=w * c,
        data=np.ascontiguousarray(pixels).ravel(),
    )


def odom_msg(ts, ros1, ns, pose, velocity):
    T = ts.types
    half = pose[2] / 2
    q = T["geometry_msgs/msg/Quaternion"](
        x=0.0, y=0.0, z=float(np.sin(half)), w=float(np.cos(half))
    )
    p = T["geometry_msgs/msg/Pose"](
        position=T["geometry_msgs/msg/Point"](x=float(pose[0]), y=float(pose[1]), z=0.0),
        orientation=q,
    )
    vec = T["geometry_msgs/msg/Vector3"]
    twist = T["geometry_msgs/msg/Twist"](
        linear=vec(x=float(velocity[0]), y=0.0, z=0.0),
        angular=vec(x=0.0, y=0.0, z=float(velocity[1])),
    )
    return T["nav_msgs/msg/Odometry"](
        header=_header(ts, ros1, ns, "odom"),
        child_frame_id="base_link",
        pose=T["geometry_msgs/msg/PoseWithCovariance"](pose=p, covariance=np.zeros(36)),
        twist=T["geometry_msgs/msg/TwistWithCovariance"](twist=twist, covariance=np.zeros(36)),
    )


def write_bag(
    path: Path, drive: Drive, *, ros: int = 2, encoding: str = "rgb8", mcap: bool = False
) -> Path:
    """Write ``drive`` as a ROS 1 ``.bag`` (``ros=1``) or a ROS 2 bag directory (``ros=2``,
    SQLite, or MCAP with ``mcap``), messages in stamp order, each logged at its stamp."""
    ros1 = ros == 1
    ts = get_typestore(Stores.ROS1_NOETIC if ros1 else Stores.LATEST)

    def ns(t):
        return drive.start_ns + round(float(t) * 1e9)

    msgs = []
    logged = drive.t_scan if drive.scan_log_times is None else drive.scan_log_times
    for t, log, r in zip(drive.t_scan, logged, drive.ranges, strict=True):
        msg = scan_msg(ts, ros1, ns(t), r, drive.angles, drive.range_max, drive.increment)
        msgs.append((ns(log), SCAN, msg))
    for t, img in zip(drive.t_image, drive.images, strict=True):
        msgs.append((ns(t), IMAGE, image_msg(ts, ros1, ns(t), img, encoding)))
    for t, p, v in zip(drive.t_odom, drive.poses, drive.velocities, strict=True):
        msgs.append((ns(t), ODOM, odom_msg(ts, ros1, ns(t), p, v)))
    for topic, items in drive.extra:
        msgs += [(ns(t), topic, make(ts, ros1, ns(t))) for t, make in items]
    storage = StoragePlugin.MCAP if mcap else StoragePlugin.SQLITE3
    writer = Writer1(path) if ros1 else Writer2(path, version=9, storage_plugin=storage)
    with writer:
        conns = {}
        for _, topic, msg in msgs:
            if topic not in conns:
                conns[topic] = writer.add_connection(topic, msg.__msgtype__, typestore=ts)
        for t, topic, msg in sorted(msgs, key=lambda m: m[0]):
            raw = (
                ts.serialize_ros1(msg, msg.__msgtype__)
                if ros1
                else ts.serialize_cdr(msg, msg.__msgtype__)
            )
            writer.write(conns[topic], t, raw)
    return path
