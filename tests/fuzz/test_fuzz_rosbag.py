"""The harness on the ROS bag importer: ROS 1 bags and ROS 2 SQLite files truncated and
flipped, special numbers in any stream (ranges, angles, poses, velocities, stamps, the
sensor's maximum range), scans of changing beam count, PNG headers claiming 40000x40000,
message definitions that refer to themselves, two bags of different setups, and special files
at the bag's path or inside a ROS 2 bag. Each gives a RosbagImportError naming the bag, with
nothing left on disk, or a dataset the dataset reader accepts and that holds possible values."""

import dataclasses
import shutil

import cv2
import numpy as np
import pytest
from rosbags.rosbag1 import Writer
from rosbags.rosbag2 import Writer as Writer2
from rosbags.typesys import Stores, get_types_from_msg, get_typestore

from sim.dataset import load_dataset
from sim.readers.rosbag import RosbagImportError, import_rosbags
from tests.fuzz.harness import SPECIAL_FILES, Judge, case_count, flipped, special_file, truncated
from tests.fuzz.test_fuzz_dataset import _valid
from tests.sim.readers import rosbag_fixtures
from tests.sim.readers.rosbag_fixtures import ODOM, write_bag
from tests.sim.readers.test_rosbag import TINY, _tiny_drive

KINDS = ("truncated", "flipped", "value", "value", "beams", "png", "loop", "setups", "special file")
NUMBERS = (np.nan, np.inf, -np.inf, 1e300, -1e300, -1.0, 0.0, 1e-320, 1e7, -(2.0**63))
FIELDS = ("ranges", "angles", "poses", "velocities", "t_scan", "t_odom", "t_image", "range_max")


def _png_claiming(width: int, height: int) -> np.ndarray:
    """A real PNG's first bytes with the IHDR's size replaced."""
    _, buf = cv2.imencode(".png", np.zeros((4, 6, 3), np.uint8))
    data = bytearray(buf.tobytes())
    data[16:24] = width.to_bytes(4, "big") + height.to_bytes(4, "big")
    return np.frombuffer(bytes(data), np.uint8)


def _drive(kind, rng):
    if kind != "value":
        return _tiny_drive()
    field = FIELDS[int(rng.integers(len(FIELDS)))]
    value = NUMBERS[int(rng.integers(len(NUMBERS)))]
    if field.startswith("t_"):  # a stamp is a whole number of ns: out of order, far, repeated
        value = float(rng.choice([0.0, 0.25, 0.5, 0.9, 1e3, 1e8]))
    if field in ("range_max", "angles") and abs(value) > 3e38:  # float32 fields: no 1e300
        value = float(np.sign(value)) * np.inf
    if field == "range_max":
        return _tiny_drive(range_max=value)
    a = np.array(getattr(_tiny_drive(), field), dtype=float)
    a.flat[int(rng.integers(a.size))] = value
    return _tiny_drive(**{field: a})


def _loop_bag(path, ros: int):
    """A ROS 1 bag, or a ROS 2 bag that carries its definitions, whose LaserScan definition
    holds a LaserScan."""
    msgtype, msgdef = "sensor_msgs/msg/LaserScan", "float32 angle_min\nsensor_msgs/LaserScan x\n"
    latest = get_typestore(Stores.LATEST)
    if ros == 2:
        with Writer2(path, version=9) as writer:
            conn = writer.add_connection(
                "/scan", msgtype, msgdef=msgdef, rihs01="RIHS01_" + "0" * 64
            )
            writer.write(conn, 1, b"\x00" * 16)
            writer.add_connection(ODOM, "nav_msgs/msg/Odometry", typestore=latest)
        return path
    store = get_typestore(Stores.EMPTY)
    store.register(get_types_from_msg(msgdef, msgtype))
    with Writer(path) as writer:
        conn = writer.add_connection(
            "/scan", msgtype, msgdef=msgdef, md5sum=store.generate_msgdef(msgtype)[1]
        )
        writer.write(conn, 1, b"\x00" * 16)
        writer.add_connection(ODOM, "nav_msgs/msg/Odometry", typestore=latest)
    return path


def _case(folder, kind, rng, case, monkeypatch):
    """``[bags]`` of the case, written in ``folder``."""
    ros = 1 + case % 2
    name = folder / ("drive.bag" if ros == 1 else "drive")
    if kind == "loop":  # laser and odometry only, as _import reads a bag named loop
        return [_loop_bag(folder / ("loop.bag" if ros == 1 else "loop"), ros)]
    if kind == "png":
        real = rosbag_fixtures.image_msg
        size = int(rng.choice([40000, 5000, 65535]))

        def claiming(*args, **kwargs):
            msg = real(*args, **kwargs)
            msg.data = _png_claiming(size, size)
            return msg

        with monkeypatch.context() as m:
            m.setattr(rosbag_fixtures, "image_msg", claiming)
            return [write_bag(name, _tiny_drive(), ros=ros, encoding="png")]
    drive = _drive(kind, rng)
    if kind == "beams":  # one scan of another beam count
        ranges = list(drive.ranges)
        ranges[int(rng.integers(len(ranges)))] = np.full(int(rng.choice([3, 6, 400])), 2.0)
        drive = dataclasses.replace(drive, ranges=ranges)
    with np.errstate(over="ignore"):  # 1e300 as a float32 range is inf
        bag = write_bag(name, drive, ros=ros)
    if kind == "setups":  # a second bag of another laser
        angles = np.linspace(-1.0, 1.0, 5)
        other = write_bag(
            folder / ("other.bag" if ros == 1 else "other"), _tiny_drive(angles=angles), ros=ros
        )
        return [bag, other]
    target = bag if ros == 1 else next(bag.glob("*.db3"))
    if kind in ("truncated", "flipped"):
        data = target.read_bytes()
        target.write_bytes(truncated(data, rng) if kind == "truncated" else flipped(data, rng, 2))
    elif kind == "special file":
        specials = [s for s in SPECIAL_FILES if s != "dangling link"]
        special_file(target if rng.random() < 0.5 else bag, specials[case % len(specials)])
    return [bag]


def _import(bags):
    out = bags[0].parent / "out"
    loop = bags[0].stem == "loop"
    try:
        import_rosbags(
            bags, out, dataclasses.replace(TINY, image_topic=None) if loop else TINY, progress=False
        )
    finally:
        left = [p.name for p in bags[0].parent.iterdir() if p.name.startswith((".out", "out"))]
        assert not left or (out / "meta.json").is_file(), f"left half-written: {left}"
    return load_dataset(out)


@pytest.mark.parametrize("seed", [0, 1])
def test_every_kind_of_damage_gives_an_import_error_or_a_valid_dataset(tmp_path, monkeypatch, seed):
    rng = np.random.default_rng(500 + seed)
    judge = Judge(_import, RosbagImportError, _valid, seconds=10.0)
    n = case_count(40) // 2  # a case writes and imports a bag: ~0.3 s
    for case in range(n):
        kind = KINDS[case % len(KINDS)]
        folder = tmp_path / f"case{case}"
        folder.mkdir()
        bags = _case(folder, kind, rng, case, monkeypatch)
        judge(kind, bags, names=bags[-1].name if kind == "setups" else bags[0].name)
        shutil.rmtree(folder)
    judge.assert_clean(least=n)
    for kind in ("png", "loop", "special file", "setups"):
        assert judge.outcomes[kind, "refused"] > 0, kind
