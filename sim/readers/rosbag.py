"""Bring a robot's own log in: ROS 1 and ROS 2 bags to the project's dataset format.

Each bag (a ROS 1 ``.bag`` file or a ROS 2 bag directory, read with the pure-Python
``rosbags`` package) becomes one sequence, one drive; the bags of one import are drives through
the same place (``world``). Three streams are read, by header stamp:

- ``sensor_msgs/LaserScan``: every scan is a candidate frame;
- ``sensor_msgs/Image`` or ``sensor_msgs/CompressedImage``: stored as RGB;
- ``nav_msgs/Odometry``: planar pose (x, y, yaw) and velocity
(:mod:`sim.readers.ros_messages` turns each message into arrays and says how).

The alignment rule: a scan at stamp ``t`` becomes a frame when an image lies within
``image_tolerance`` of ``t`` (the nearest one is taken) and two consecutive odometry messages
bracket ``t`` at most ``odom_max_gap`` apart (the pose is interpolated linearly between them,
yaw unwrapped; nothing is extrapolated). Of those, a frame is kept when the robot has moved
``min_travel`` or turned ``min_turn`` since the last kept frame (either at 0 keeps every one).
Without an image topic (``image_topic=None``: a robot with a laser and wheel odometry only)
every scan with odometry around it is a candidate frame, and the dataset has no images
(``"camera": false`` in ``meta.json``); the laser grouping runs on it, the methods on images
say that the camera is missing.
``odometry`` is the laser's pose: the robot's odometry composed with ``laser_offset``;
``commands`` are the odometry's measured velocity (v, omega) at ``t``; ``times`` are seconds
since the sequence's first frame. There is no ground truth: no ``poses`` or ``labels``.

Bad input is refused with an error naming the bag, topic and message: a damaged bag (whatever
rosbags or SQLite raise becomes a ``RosbagImportError``), a missing topic (the bag's topics are
listed), another message type, a scan whose range count disagrees with its angles, scans or
images that change shape, stamps that repeat or go backwards, values beyond
:mod:`common.bounds`, bags in which no beam has a return. The dataset is built in a temporary
directory beside ``out`` and renamed into place when complete: nothing half-written is left.
"""

from __future__ import annotations

import os
import shutil
import tempfile
from collections.abc import Sequence as SequenceOf
from dataclasses import asdict, dataclass
from pathlib import Path

import numpy as np

from common.fileio import write_json
from common.geometry import se2_compose, wrap_angle
from sim import dataset as ds
from sim.readers.ros_messages import (
    RosbagImportError,
    Stream,
    check_bag_path,
    damage_errors,
    odometry_values,
    read_images,
    scan_geometry,
    scan_ranges,
    stamp_ns,
)

SCAN_TYPES = ("sensor_msgs/msg/LaserScan",)
IMAGE_TYPES = ("sensor_msgs/msg/Image", "sensor_msgs/msg/CompressedImage")
ODOM_TYPES = ("nav_msgs/msg/Odometry",)


@dataclass(frozen=True)
class ImportSettings:
    """The topics to read and the alignment rule (see the module docstring); stored in
    ``meta.json``. Times in seconds, distances in metres, angles in radians.

    Parameters
    ----------
    scan_topic, odom_topic : str
        The topics of the ``LaserScan`` and ``Odometry`` messages.
    image_topic : str or None
        The topic of the ``Image`` (or ``CompressedImage``) messages; None: the robot has no
        camera, the dataset holds scans and odometry only.
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

    scan_topic: str
    image_topic: str | None
    odom_topic: str
    world: str = "robot"
    image_tolerance: float = 0.1
    odom_max_gap: float = 0.5
    min_travel: float = 0.1
    min_turn: float = 0.2
    laser_offset: tuple[float, float, float] = (0.0, 0.0, 0.0)

    def __post_init__(self):
        for name in ("scan_topic", "image_topic", "odom_topic", "world"):
            value = getattr(self, name)
            if name == "image_topic" and value is None:
                continue
            if not isinstance(value, str) or not value:
                optional = " (or None: no camera)" if name == "image_topic" else ""
                raise ValueError(f"{name} must be a non-empty string{optional}, got {value!r}")
        for name in ("image_tolerance", "odom_max_gap"):
            if not (np.isfinite(getattr(self, name)) and getattr(self, name) > 0):
                raise ValueError(f"{name} must be a number > 0, got {getattr(self, name)}")
        for name in ("min_travel", "min_turn"):
            if not (np.isfinite(getattr(self, name)) and getattr(self, name) >= 0):
                raise ValueError(f"{name} must be a number >= 0, got {getattr(self, name)}")
        if len(self.laser_offset) != 3 or not np.all(np.isfinite(self.laser_offset)):
            raise ValueError(f"laser_offset must be 3 finite numbers, got {self.laser_offset}")


def _connections(reader, bag: Path, settings: ImportSettings) -> dict:
    """The connection of each stream, checked for the expected message type."""
    topics = reader.topics
    out = {}
    for key, topic, types, flag in (
        ("scan", settings.scan_topic, SCAN_TYPES, "--scan-topic"),
        ("image", settings.image_topic, IMAGE_TYPES, "--image-topic"),
        ("odom", settings.odom_topic, ODOM_TYPES, "--odom-topic"),
    ):
        if topic is None:  # no camera
            continue
        if topic not in topics:
            have = ", ".join(f"{t} ({i.msgtype})" for t, i in sorted(topics.items())) or "none"
            raise RosbagImportError(f"{bag}: no topic {topic!r} ({flag}); its topics: {have}")
        conns = [c for c in reader.connections if c.topic == topic]
        bad = sorted({c.msgtype for c in conns} - set(types))
        if bad:
            raise RosbagImportError(
                f"{bag}: topic {topic!r} carries {', '.join(bad)}; expected {' or '.join(types)}"
            )
        out[key] = conns
    return out


def read_bag(bag: str | os.PathLike, settings: ImportSettings, progress: bool = True) -> dict:
    """One bag's aligned frames: the arrays of one dataset sequence (see the module
    docstring), plus ``start_stamp_ns``, ``range_max`` and ``dropped`` (scans left out, by
    reason)."""
    from rosbags.highlevel import AnyReader, AnyReaderError
    from rosbags.typesys import Stores, get_typestore
    from tqdm.auto import tqdm

    bag = Path(bag)
    check_bag_path(bag)
    scans, images, odom = (Stream(bag, t) for t in (settings.scan_topic,
                                                      settings.image_topic or "no camera",
                                                      settings.odom_topic))  # fmt: skip
    try:
        with AnyReader([bag], default_typestore=get_typestore(Stores.LATEST)) as reader:
            conns = _connections(reader, bag, settings)
            wanted = [c for cs in conns.values() for c in cs]
            geometry = None
            counts = {"scan": 0, "image": 0, "odom": 0}
            total = sum(c.msgcount for c in wanted)
            bar = tqdm(total=total, desc=f"read {bag.name}", unit="msg", disable=not progress)
            with bar:
                for conn, _, raw in reader.messages(connections=wanted):
                    key = next(k for k, cs in conns.items() if conn in cs)
                    i, counts[key] = counts[key], counts[key] + 1
                    where = f"{bag.name}: {conn.topic} message {i}"
                    try:
                        msg = reader.deserialize(raw, conn.msgtype)
                    except AnyReaderError as err:
                        raise RosbagImportError(f"{where}: cannot be decoded ({err})") from err
                    if key == "scan":
                        g = scan_geometry(msg, where)
                        if geometry is None:
                            geometry = g
                        elif g[0] != geometry[0] or not np.allclose(g[1:3], geometry[1:3]):
                            raise RosbagImportError(
                                f"{where}: the scan's geometry (beams, angle_min, "
                                f"angle_increment) = {g[:3]} differs from the first scan's "
                                f"{geometry[:3]}"
                            )
                        scans.add(i, stamp_ns(msg), scan_ranges(msg))
                    elif key == "image":
                        images.add(i, stamp_ns(msg), None)
                    else:
                        odom.add(i, stamp_ns(msg), odometry_values(msg, where))
                    bar.update()
            camera = settings.image_topic is not None
            for stream, least in ((scans, 1), (images, int(camera)), (odom, 2)):
                if len(stream.stamps) < least:
                    raise RosbagImportError(
                        f"{stream.where}: {len(stream.stamps)} messages; at least {least} needed"
                    )
            frames, image_index, dropped = _align(scans, images, odom, settings)
            pictures = (
                read_images(reader, conns["image"], image_index, bag, settings) if camera else None
            )
    except RosbagImportError:
        raise
    except (AnyReaderError, *damage_errors()) as err:  # OSError: files missing or unreadable
        raise RosbagImportError(
            f"{bag}: cannot be read as a ROS bag ({type(err).__name__}: {err})"
        ) from err
    n_beams, angle_min, inc, range_max, angle_max = geometry
    if abs((angle_max - angle_min) / inc + 1 - n_beams) < 0.5:  # both ends: float32 inc drifts
        angles = np.linspace(angle_min, angle_max, n_beams)
    else:
        angles = angle_min + inc * np.arange(n_beams)
    stamps = np.asarray(scans.stamps, dtype=np.int64)[frames["scan"]]
    ranges = np.stack([scans.values[k] for k in frames["scan"]]).astype(np.float32)
    if not np.isfinite(ranges).any():
        raise RosbagImportError(
            f"{scans.where}: no beam of any of the {len(ranges)} frames has a return (every "
            "reading is NaN, infinite, below range_min or at or beyond range_max); check "
            "range_min and range_max"
        )
    return {
        "images": pictures,
        "scans": ranges,
        "angles": angles.astype(np.float32),
        "odometry": frames["odometry"],
        "commands": frames["commands"],
        "times": (stamps - stamps[0]) / 1e9,
        "start_stamp_ns": int(stamps[0]),
        "range_max": range_max,
        "dropped": dropped,
    }


def _align(scans: Stream, images: Stream, odom: Stream, settings: ImportSettings):
    """Which scans become frames, their image (index into the image topic), odometry and
    velocity; and how many scans were dropped, by reason."""
    t = np.asarray(scans.stamps, dtype=np.int64)
    if not images.stamps:  # no camera: every scan may be a frame
        images = Stream(Path("no camera"), "no camera")
        images.stamps = scans.stamps
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
    keep = _spaced(pose, settings.min_travel, settings.min_turn)
    dropped["closer than min_travel and min_turn"] = int(len(idx) - keep.size)
    if keep.size == 0:
        raise RosbagImportError(
            f"{scans.where}: no scan has an image within {settings.image_tolerance} s and "
            f"odometry around it ({dropped}); check the topics and tolerances"
        )
    frames = {
        "scan": idx[keep],
        "odometry": pose[keep],
        "commands": interp[keep, 3:5],
    }
    return frames, nearest[idx[keep]], dropped


def _spaced(pose: np.ndarray, min_travel: float, min_turn: float) -> np.ndarray:
    """Indices of the frames kept: the first, then each that moved ``min_travel`` or turned
    ``min_turn`` since the last kept one (either at 0 keeps every frame)."""
    keep = [0] if len(pose) else []
    for i in range(1, len(pose)):
        last = pose[keep[-1]]
        moved = np.hypot(*(pose[i, :2] - last[:2]))
        turned = abs(wrap_angle(pose[i, 2] - last[2]))
        if moved >= min_travel or turned >= min_turn:
            keep.append(i)
    return np.asarray(keep, dtype=int)


def import_rosbags(
    bags: SequenceOf[str | os.PathLike],
    out: str | os.PathLike,
    settings: ImportSettings,
    *,
    overwrite: bool = False,
    progress: bool = True,
) -> Path:
    """Import ``bags`` (drives through one place) as a dataset in ``out``; returns ``out``.

    ``out`` must not hold anything yet (an existing dataset is replaced with ``overwrite``).
    The dataset is written to a temporary directory beside it and renamed when complete.
    """
    out = Path(out)
    if not bags:
        raise ValueError("no bags given")
    if out.exists() and any(out.iterdir()):
        if not overwrite or not (out / ds.META_FILE).is_file():
            raise FileExistsError(
                f"{out} is not empty; choose another directory"
                + (
                    " or pass overwrite=True (--overwrite)"
                    if (out / ds.META_FILE).is_file()
                    else ""
                )
            )
    seqs = {}
    for bag in map(Path, bags):
        name = bag.stem if bag.suffix == ".bag" else bag.name
        name = name if name not in seqs else f"{name}-{len(seqs)}"
        seqs[name] = (bag, read_bag(bag, settings, progress))
    first_bag, first = next(iter(seqs.values()))
    for bag, arrays in seqs.values():
        same_beams = arrays["angles"].shape == first["angles"].shape and np.allclose(
            arrays["angles"], first["angles"]
        )
        size, first_size = (_image_size(a) for a in (arrays, first))
        if not (same_beams and size == first_size):
            raise RosbagImportError(
                f"{bag}: its scans ({len(arrays['angles'])} beams) or images ({size}) differ "
                f"from {first_bag.name}'s ({len(first['angles'])} beams, {first_size}); import "
                "the bags of one robot setup together"
            )
    out.parent.mkdir(parents=True, exist_ok=True)
    tmp = Path(tempfile.mkdtemp(dir=out.parent, prefix=f".{out.name}.", suffix=".tmp"))
    try:
        _write(tmp, seqs, settings, first)
        try:
            ds.load_dataset(tmp)  # the reader's own checks on what was written
        except ds.DatasetError as err:
            names = ", ".join(bag.name for bag, _ in seqs.values())
            raise RosbagImportError(
                f"{names}: imported data fail the dataset's checks: {err}"
            ) from err
        if out.exists():
            old = out.with_name(f".{out.name}.old")
            shutil.rmtree(old, ignore_errors=True)
            out.rename(old)
            tmp.rename(out)
            shutil.rmtree(old)
        else:
            tmp.rename(out)
    except BaseException:
        shutil.rmtree(tmp, ignore_errors=True)
        raise
    return out


def _image_size(arrays: dict) -> tuple | None:
    return None if arrays["images"] is None else arrays["images"].shape[1:]


def _write(directory: Path, seqs: dict, settings: ImportSettings, first: dict) -> None:
    camera = first["images"] is not None
    angles = first["angles"]
    meta = {
        "format": ds.FORMAT_NAME,
        "schema_version": ds.SCHEMA_VERSION,
        "ground_truth": False,
        "settings": {
            "source": "rosbag",
            "import": {**asdict(settings), "laser_offset": list(settings.laser_offset)},
            "bags": [str(bag) for bag, _ in seqs.values()],
            "laser": {
                "beams": len(angles),
                "fov": float(angles[-1] - angles[0]),
                "max_range": max(a["range_max"] for _, a in seqs.values()),
            },
            "camera": (
                {"width": int(first["images"].shape[2]), "height": int(first["images"].shape[1])}
                if camera
                else None
            ),
        },
        "camera": camera,
        "manifolds": [],
        "sequences": {},
        "complete": False,
    }
    for name, (bag, arrays) in seqs.items():
        file = f"{name}.npz"
        keys = ("images", "scans", "angles", "odometry", "commands", "times")
        data = {k: arrays[k] for k in keys if arrays[k] is not None}
        meta["sequences"][name] = {
            "file": file,
            "world": settings.world,
            "frames": len(arrays["times"]),
            "sha256": ds.write_sequence(directory / file, data),
            "bag": bag.name,
            "start_stamp_ns": arrays["start_stamp_ns"],
            "dropped_scans": arrays["dropped"],
        }
    meta["complete"] = True
    write_json(directory / ds.META_FILE, meta)
