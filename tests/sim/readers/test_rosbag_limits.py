"""Bounded reads of ROS bags: an image whose header claims more than MAX_IMAGE_PIXELS is
refused before it is decoded, and a message definition that refers to itself, or nests deeper
than MAX_MESSAGE_NESTING, before any message is; each a RosbagImportError naming the bag, the
topic or the message, never cv2.error or RecursionError."""

import dataclasses
from types import SimpleNamespace

import cv2
import numpy as np
import pytest
from rosbags.rosbag1 import Writer
from rosbags.typesys import Stores, get_types_from_msg, get_typestore

from sim.readers import ros_messages
from sim.readers.ros_messages import (
    MAX_IMAGE_PIXELS,
    MAX_MESSAGE_NESTING,
    compressed_size,
    decode_image,
    nesting_problem,
)
from sim.readers.rosbag import RosbagImportError, import_rosbags
from tests.sim.readers.fuzzing import budget
from tests.sim.readers.rosbag_fixtures import ODOM
from tests.sim.readers.test_rosbag import TINY

COMPRESSED = "sensor_msgs/msg/CompressedImage"


def _png_claiming(width: int, height: int) -> bytes:
    """A real PNG's first bytes with the IHDR's size replaced (its CRC no longer matches)."""
    _, buf = cv2.imencode(".png", np.zeros((2, 3, 3), np.uint8))
    data = bytearray(buf.tobytes())
    data[16:24] = width.to_bytes(4, "big") + height.to_bytes(4, "big")
    return bytes(data)


@pytest.mark.parametrize("ext", [".png", ".jpg"])
def test_the_header_states_the_size(ext):
    _, buf = cv2.imencode(ext, np.zeros((24, 32, 3), np.uint8))
    assert compressed_size(buf.tobytes()) == (32, 24)
    assert compressed_size(b"GIF89a") is None and compressed_size(b"\xff\xd8\xff") is None


def test_a_compressed_image_claiming_40000x40000_is_refused_before_decoding():
    msg = SimpleNamespace(data=np.frombuffer(_png_claiming(40000, 40000), np.uint8), format="png")
    with (
        budget(5),
        pytest.raises(
            RosbagImportError,
            match=r"bag.bag: /cam message 3: a 40000x"
            r"40000 image; at most MAX_IMAGE_PIXELS = 16777216",
        ),
    ):
        decode_image(msg, COMPRESSED, "bag.bag: /cam message 3")


def test_an_image_opencv_refuses_is_an_import_error(monkeypatch):
    monkeypatch.setattr(ros_messages, "MAX_IMAGE_PIXELS", 10**12)  # past ours, to OpenCV's
    msg = SimpleNamespace(data=np.frombuffer(_png_claiming(40000, 40000), np.uint8), format="png")
    with budget(5), pytest.raises(RosbagImportError, match="OpenCV cannot decode it"):
        decode_image(msg, COMPRESSED, "bag.bag: /cam message 3")


def test_a_raw_image_beyond_the_cap_is_refused():
    msg = SimpleNamespace(
        data=np.zeros(12, np.uint8), encoding="rgb8", height=5000, width=5000, step=15000
    )
    with pytest.raises(RosbagImportError, match="a 5000x5000 image"):
        decode_image(msg, "sensor_msgs/msg/Image", "bag.bag: /cam message 0")
    assert 4096 * 4096 == MAX_IMAGE_PIXELS


def _name(typename):
    return (2, typename)  # rosbags' Nodetype.NAME


def test_nesting_is_walked_to_the_cap():
    defs = dict(get_typestore(Stores.LATEST).fielddefs)
    for msgtype in ("sensor_msgs/msg/LaserScan", "nav_msgs/msg/Odometry", COMPRESSED):
        assert nesting_problem(defs, msgtype) is None
    defs["a/msg/Loop"] = ([], [("x", (4, ((2, "a/msg/B"), 0)))])  # a sequence of B
    defs["a/msg/B"] = ([], [("back", _name("a/msg/Loop"))])
    assert nesting_problem(defs, "a/msg/Loop") == (
        "message type a/msg/Loop refers to itself (a/msg/Loop -> a/msg/B -> a/msg/Loop)"
    )
    for k in range(MAX_MESSAGE_NESTING + 1):
        defs[f"d/msg/T{k}"] = ([], [("next", _name(f"d/msg/T{k + 1}"))])
    assert "nests more than MAX_MESSAGE_NESTING = 32" in nesting_problem(defs, "d/msg/T0")
    assert nesting_problem(defs, "d/msg/T2") is None  # 31 deep, then a type without fields


def test_a_bag_whose_scan_definition_refers_to_itself_is_refused(tmp_path):
    msgtype, msgdef = (
        "sensor_msgs/msg/LaserScan",
        "float32 angle_min\nsensor_msgs/LaserScan inner\n",
    )
    store = get_typestore(Stores.EMPTY)
    store.register(get_types_from_msg(msgdef, msgtype))
    bag = tmp_path / "loop.bag"
    with Writer(bag) as writer:  # its hash as the bag's reader computes it: past that check
        conn = writer.add_connection(
            "/scan", msgtype, msgdef=msgdef, md5sum=store.generate_msgdef(msgtype)[1]
        )
        writer.write(conn, 1, b"\x00" * 16)
        writer.add_connection(ODOM, "nav_msgs/msg/Odometry", typestore=get_typestore(Stores.LATEST))
    laser_only = dataclasses.replace(TINY, image_topic=None)
    with (
        budget(10),
        pytest.raises(
            RosbagImportError,
            match=r"loop.bag: /scan: message type "
            r"sensor_msgs/msg/LaserScan refers to itself",
        ),
    ):
        import_rosbags([bag], tmp_path / "out", laser_only, progress=False)
    assert not (tmp_path / "out").exists()


@pytest.mark.parametrize("where", ["bag", "member"])
def test_a_pipe_or_device_is_refused_without_blocking(tmp_path, where):
    import os

    if where == "bag":
        bag = tmp_path / "pipe.bag"
        os.mkfifo(bag)
        (tmp_path / "zero.bag").symlink_to("/dev/zero")
        bags = (bag, tmp_path / "zero.bag")
    else:
        bag = tmp_path / "ros2"
        bag.mkdir()
        (bag / "metadata.yaml").write_text("rosbag2_bagfile_information: {}\n")
        os.mkfifo(bag / "ros2_0.db3")
        bags = (bag,)
    for given in bags:
        with budget(5), pytest.raises(RosbagImportError, match="neither a regular file nor"):
            import_rosbags([given], tmp_path / "out", TINY, progress=False)
