"""Bring a robot's own log in: ROS 1 and ROS 2 bags to the project's dataset format.

Each bag (a ROS 1 ``.bag`` file or a ROS 2 bag directory, read with the pure-Python
``rosbags`` package) becomes one sequence, one drive; the bags of one import are drives through
the same place (``world``). Three streams are read, by header stamp:

- ``sensor_msgs/LaserScan``: every scan is a candidate frame;
- ``sensor_msgs/Image`` or ``sensor_msgs/CompressedImage``: stored as RGB;
- ``nav_msgs/Odometry``: planar pose (x, y, yaw) and velocity
(`sim.readers.ros_messages` turns each message into arrays and says how).

The alignment rule is `sim.readers.alignment`'s: each scan with an image near it and
odometry around it is a frame, kept when the robot has moved or turned enough since the last.
Without an image topic (``image_topic=None``: a robot with a laser and wheel odometry only)
the dataset has no images (``"camera": false`` in ``meta.json``); without a scan topic
(``scan_topic=None``: a camera and wheel odometry only) the images are the frames and the
dataset has no scans or angles (``"laser": false``). The grouping needs the laser and the
methods on images the camera; each says which sensor a dataset lacks.
``odometry`` is the laser's pose: the robot's odometry composed with ``laser_offset``;
``commands`` are the odometry's measured velocity (v, omega) at ``t``; ``times`` are seconds
since the sequence's first frame. There is no ground truth: no ``poses`` or ``labels``.

Bad input is refused with an error naming the bag, topic and message: a damaged bag (whatever
rosbags or SQLite raise becomes a ``RosbagImportError``), a missing topic (the bag's topics are
listed), another message type, a scan whose range count disagrees with its angles, scans or
images that change shape, stamps that repeat or go backwards, values beyond
`common.bounds`, bags in which no beam has a return, a named pipe or device in place of a
bag or its files, images beyond ``MAX_IMAGE_PIXELS`` and message definitions that refer to
themselves or nest beyond ``MAX_MESSAGE_NESTING`` (`sim.readers.ros_messages`). The
dataset is built in a temporary directory beside ``out`` and renamed into place when complete:
nothing half-written is left.
"""

from __future__ import annotations

import os
import shutil
import tempfile
from collections.abc import Sequence as SequenceOf
from dataclasses import asdict
from pathlib import Path

import numpy as np

from common.fileio import write_json
from sim import dataset as ds
from sim.readers.alignment import ImportSettings, align
from sim.readers.ros_messages import (
    RosbagImportError,
    Stream,
    check_bag_path,
    damage_errors,
    nesting_problem,
    odometry_values,
    read_images,
    scan_geometry,
    scan_ranges,
    stamp_ns,
)

SCAN_TYPES = ("sensor_msgs/msg/LaserScan",)
IMAGE_TYPES = ("sensor_msgs/msg/Image", "sensor_msgs/msg/CompressedImage")
ODOM_TYPES = ("nav_msgs/msg/Odometry",)
__all__ = ["ImportSettings", "import_rosbags", "read_bag"]


def _connections(reader, bag: Path, settings: ImportSettings) -> dict:
    """Return the connections of each stream, checked for the expected message type."""
    topics = reader.topics
    out = {}
    for key, topic, types, flag in (
        ("scan", settings.scan_topic, SCAN_TYPES, "--scan-topic"),
        ("image", settings.image_topic, IMAGE_TYPES, "--image-topic"),
        ("odom", settings.odom_topic, ODOM_TYPES, "--odom-topic"),
    ):
        if topic is None:  # no camera, or no laser
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
    """Read one bag's aligned frames.

    Parameters
    ----------
    bag : path-like
        The ROS 1 ``.bag`` file or ROS 2 bag folder.
    settings : ImportSettings
        The topics and alignment.
    progress : bool, default True
        Show a progress bar.

    Returns
    -------
    dict
        The arrays of one dataset sequence (see the module docstring), plus
        ``start_stamp_ns``, ``range_max`` and ``dropped`` (scans, or images without a laser,
        left out, by reason).
    """
    from rosbags.highlevel import AnyReader, AnyReaderError
    from rosbags.typesys import Stores, get_typestore
    from tqdm.auto import tqdm

    bag = Path(bag)
    check_bag_path(bag)
    scans, images, odom = (
        Stream(bag, t)
        for t in (
            settings.scan_topic or "no laser",
            settings.image_topic or "no camera",
            settings.odom_topic,
        )
    )
    try:
        with AnyReader([bag], default_typestore=get_typestore(Stores.LATEST)) as reader:
            conns = _connections(reader, bag, settings)
            wanted = [c for cs in conns.values() for c in cs]
            for conn in wanted:
                problem = nesting_problem(reader.typestore.fielddefs, conn.msgtype)
                if problem:
                    raise RosbagImportError(f"{bag.name}: {conn.topic}: {problem}")
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
            camera, laser = settings.camera, settings.laser
            for stream, least in ((scans, int(laser)), (images, int(camera)), (odom, 2)):
                if len(stream.stamps) < least:
                    raise RosbagImportError(
                        f"{stream.where}: {len(stream.stamps)} messages; at least {least} needed"
                    )
            frames, image_index, dropped = align(scans, images, odom, settings)
            pictures = (
                read_images(reader, conns["image"], image_index, bag, settings) if camera else None
            )
    except RosbagImportError:
        raise
    except (AnyReaderError, *damage_errors()) as err:  # OSError: files missing or unreadable
        raise RosbagImportError(
            f"{bag}: cannot be read as a ROS bag ({type(err).__name__}: {err})"
        ) from err
    clock = scans if laser else images
    stamps = np.asarray(clock.stamps, dtype=np.int64)[frames["clock"]]
    ranges = angles = range_max = None  # without a laser
    if laser:
        ranges, angles, range_max = _laser_arrays(scans, frames["clock"], geometry)
    return {
        "images": pictures,
        "scans": ranges,
        "angles": angles,
        "odometry": frames["odometry"],
        "commands": frames["commands"],
        "times": (stamps - stamps[0]) / 1e9,
        "start_stamp_ns": int(stamps[0]),
        "range_max": range_max,
        "dropped": dropped,
    }


def _laser_arrays(scans: Stream, index: np.ndarray, geometry: tuple):
    """Return the frames' ranges (float32), the beams' angles (float32) and the range_max."""
    n_beams, angle_min, inc, range_max, angle_max = geometry
    if abs((angle_max - angle_min) / inc + 1 - n_beams) < 0.5:  # both ends: float32 inc drifts
        angles = np.linspace(angle_min, angle_max, n_beams)
    else:
        angles = angle_min + inc * np.arange(n_beams)
    ranges = np.stack([scans.values[k] for k in index]).astype(np.float32)
    if not np.isfinite(ranges).any():
        raise RosbagImportError(
            f"{scans.where}: no beam of any of the {len(ranges)} frames has a return (every "
            "reading is NaN, infinite, below range_min or at or beyond range_max); check "
            "range_min and range_max"
        )
    return ranges, angles.astype(np.float32), range_max


def import_rosbags(
    bags: SequenceOf[str | os.PathLike],
    out: str | os.PathLike,
    settings: ImportSettings,
    *,
    overwrite: bool = False,
    progress: bool = True,
) -> Path:
    """Import ``bags`` (drives through one place) as a dataset in ``out``; return ``out``.

    ``out`` must not hold anything yet (an existing dataset is replaced with ``overwrite``).
    The dataset is written to a temporary directory beside it and renamed when complete.

    Parameters
    ----------
    bags : sequence of path-like
        The bags, one sequence each, all of one robot setup.
    out : path-like
        The dataset's folder.
    settings : ImportSettings
        The topics and alignment.
    overwrite : bool, default False
        Replace a dataset already in ``out``.
    progress : bool, default True
        Show a progress bar.

    Returns
    -------
    Path
        ``out``.
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
        angles, first_angles = arrays["angles"], first["angles"]
        same_beams = first_angles is None or (
            angles.shape == first_angles.shape and np.allclose(angles, first_angles)
        )
        (beams, size), (first_beams, first_size) = (_setup(a) for a in (arrays, first))
        if not (same_beams and size == first_size):
            raise RosbagImportError(
                f"{bag}: its scans ({beams}) or images ({size}) differ from {first_bag.name}'s "
                f"({first_beams}, {first_size}); import the bags of one robot setup together"
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


def _setup(arrays: dict) -> tuple[str, tuple | None]:
    """Describe a bag's laser beams (in words) and its images' shape (None: no camera)."""
    beams = "no laser" if arrays["angles"] is None else f"{len(arrays['angles'])} beams"
    return beams, None if arrays["images"] is None else arrays["images"].shape[1:]


def _write(directory: Path, seqs: dict, settings: ImportSettings, first: dict) -> None:
    camera, laser = first["images"] is not None, first["angles"] is not None
    angles = first["angles"]
    meta = {
        "format": ds.FORMAT_NAME,
        "schema_version": ds.SCHEMA_VERSION,
        "ground_truth": False,
        "settings": {
            "source": "rosbag",
            "import": {**asdict(settings), "laser_offset": list(settings.laser_offset)},
            "bags": [str(bag) for bag, _ in seqs.values()],
            "laser": (
                {
                    "beams": len(angles),
                    "fov": float(angles[-1] - angles[0]),
                    "max_range": max(a["range_max"] for _, a in seqs.values()),
                }
                if laser
                else None
            ),
            "camera": (
                {"width": int(first["images"].shape[2]), "height": int(first["images"].shape[1])}
                if camera
                else None
            ),
        },
        "camera": camera,
        "laser": laser,
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
