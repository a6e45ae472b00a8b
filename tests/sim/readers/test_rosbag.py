"""Importing ROS 1 and ROS 2 bags (written here with rosbags' own writers) as datasets."""

import dataclasses
import json

import numpy as np
import pytest

from sim.camera import CameraConfig
from sim.collect import CollectionSettings, collect_dataset
from sim.dataset import load_dataset
from sim.readers.rosbag import ImportSettings, RosbagImportError, import_rosbags
from tests.sim.readers.rosbag_fixtures import (
    IMAGE,
    ODOM,
    SCAN,
    Drive,
    drive_from_sequence,
    write_bag,
)

EVERY_SCAN = ImportSettings(SCAN, IMAGE, ODOM, min_travel=0.0)
TINY = ImportSettings(SCAN, IMAGE, ODOM, min_travel=0.0, odom_max_gap=2.0)  # for _tiny_drive


@pytest.fixture(scope="module")
def sim_data(tmp_path_factory):
    settings = CollectionSettings(
        worlds=("hallway",), frames=10, seed=2, camera=CameraConfig(width=32, height=24)
    )
    path = tmp_path_factory.mktemp("sim")
    collect_dataset(path, settings, jobs=1, progress=False)
    return load_dataset(path)


def _drive(sim_data, name="hallway-left"):
    return drive_from_sequence(sim_data.sequences[name], sim_data.max_range)


def _wrap(a):
    return (a + np.pi) % (2 * np.pi) - np.pi


@pytest.mark.parametrize(
    ("ros", "encoding"), [(1, "rgb8"), (2, "bgr8"), (2, "png"), (1, "jpeg"), (2, "mono8")]
)
def test_bag_round_trips_into_a_dataset_without_ground_truth(sim_data, tmp_path, ros, encoding):
    seq = sim_data.sequences["hallway-left"]
    bag = write_bag(
        tmp_path / ("drive.bag" if ros == 1 else "drive"),
        _drive(sim_data),
        ros=ros,
        encoding=encoding,
    )
    out = import_rosbags([bag], tmp_path / "data", EVERY_SCAN, progress=False)
    data = load_dataset(out)
    assert not data.has_ground_truth and data.manifolds == [] and list(data.sequences) == ["drive"]
    got = data.sequences["drive"]
    assert got.poses is None and got.labels is None and got.world == "robot"
    assert len(got) == len(seq) and data.max_range == sim_data.max_range
    np.testing.assert_allclose(got.angles, seq.angles, atol=1e-5)
    returned = seq.scans < sim_data.max_range
    np.testing.assert_array_equal(got.scans[returned], seq.scans[returned])
    assert np.all(np.isinf(got.scans[~returned]))
    np.testing.assert_allclose(got.odometry[:, :2], seq.odometry[:, :2], atol=1e-9)
    np.testing.assert_allclose(_wrap(got.odometry[:, 2] - seq.odometry[:, 2]), 0, atol=1e-9)
    np.testing.assert_allclose(got.commands, seq.commands, atol=1e-9)
    np.testing.assert_allclose(got.times, seq.times - seq.times[0], atol=1e-9)
    if encoding == "jpeg":  # lossy
        assert np.abs(got.images.astype(int) - seq.images).mean() < 12
    elif encoding == "mono8":
        np.testing.assert_array_equal(got.images, np.repeat(seq.images[..., :1], 3, axis=3))
    else:
        np.testing.assert_array_equal(got.images, seq.images)
    meta = json.loads((out / "meta.json").read_text())
    assert meta["ground_truth"] is False and meta["settings"]["source"] == "rosbag"
    assert set(meta["sequences"]["drive"]["dropped_scans"].values()) == {0}
    with pytest.raises(Exception, match="no ground truth"):
        data.concat("labels")


def test_several_bags_are_drives_of_one_place(sim_data, tmp_path):
    bags = [
        write_bag(tmp_path / name, _drive(sim_data, name))
        for name in ("hallway-left", "hallway-right")
    ]
    data = load_dataset(import_rosbags(bags, tmp_path / "data", EVERY_SCAN, progress=False))
    runs = data.runs("robot")
    assert runs.names == ["hallway-left", "hallway-right"]
    assert runs.groups.tolist() == [0] * 10 + [1] * 10
    assert runs.poses is None and runs.labels is None and runs.max_range == sim_data.max_range
    assert len(runs.scans) == 20 and runs.images.shape == (20, 24, 32, 3)


def test_frames_are_spaced_by_travel(sim_data, tmp_path):
    bag = write_bag(tmp_path / "drive", _drive(sim_data))
    settings = dataclasses.replace(EVERY_SCAN, min_travel=8.0, min_turn=10.0)  # no turn counts
    got = load_dataset(import_rosbags([bag], tmp_path / "d", settings, progress=False))
    xy = got.sequences["drive"].odometry[:, :2]
    steps = np.hypot(*np.diff(xy, axis=0).T)
    assert 2 <= len(xy) < 10 and np.all(steps >= 8.0)


def _tiny_drive(**changes):
    """Three scans between odometry at 0 s and 1 s that crosses yaw = pi, images 10 ms off."""
    angles = np.linspace(-np.pi / 2, np.pi / 2, 5)
    fields = dict(
        t_scan=np.array([0.25, 0.5, 0.75]),
        ranges=np.array([[1.0, 2.0, np.inf, 25.0, 0.01]] * 3),
        angles=angles,
        t_image=np.array([0.26, 0.51, 0.9]),
        images=np.zeros((3, 4, 6, 3), np.uint8),
        t_odom=np.array([0.0, 1.0]),
        poses=np.array([[0.0, 0.0, 3.0], [2.0, 0.0, -3.0]]),
        velocities=np.array([[1.0, 0.5], [3.0, 0.5]]),
    )
    return Drive(**{**fields, **changes})


def test_alignment_interpolates_odometry_and_takes_the_nearest_image(tmp_path):
    bag = write_bag(tmp_path / "tiny", _tiny_drive())
    settings = dataclasses.replace(TINY, image_tolerance=0.05, laser_offset=(0.5, 0, 0))
    out = import_rosbags([bag], tmp_path / "d", settings, progress=False)
    seq = load_dataset(out).sequences["tiny"]
    assert len(seq) == 2  # the scan at 0.75 s has no image within 0.05 s
    turn = 2 * np.pi - 6.0  # from yaw 3 to -3 the short way: through pi
    yaw = _wrap(3.0 + turn * np.array([0.25, 0.5]))
    x = 2.0 * np.array([0.25, 0.5]) + 0.5 * np.cos(yaw)  # the laser 0.5 m ahead of the base
    np.testing.assert_allclose(seq.odometry[:, 0], x, atol=1e-9)
    np.testing.assert_allclose(seq.odometry[:, 1], 0.5 * np.sin(yaw), atol=1e-9)
    np.testing.assert_allclose(seq.odometry[:, 2], yaw, atol=1e-9)
    np.testing.assert_allclose(seq.commands, [[1.5, 0.5], [2.0, 0.5]])
    np.testing.assert_allclose(seq.times, [0.0, 0.25])
    # no return (inf), beyond range_max, below range_min: all +inf
    assert seq.scans[0].tolist() == [1.0, 2.0, np.inf, np.inf, np.inf]
    meta = json.loads((out / "meta.json").read_text())
    assert meta["sequences"]["tiny"]["dropped_scans"]["no image within image_tolerance"] == 1


def _refused(tmp_path, drive_or_bag, settings=TINY, match="", ros=2):
    bag = drive_or_bag
    if isinstance(drive_or_bag, Drive):
        bag = write_bag(tmp_path / ("bad.bag" if ros == 1 else "bad"), drive_or_bag, ros=ros)
    before = sorted(p.name for p in tmp_path.iterdir())
    with pytest.raises(RosbagImportError, match=match):
        import_rosbags([bag], tmp_path / "out", settings, progress=False)
    assert sorted(p.name for p in tmp_path.iterdir()) == before  # nothing written, no temp dir


@pytest.mark.parametrize("ros", [1, 2])
def test_missing_topic_lists_the_bags_topics(tmp_path, ros):
    settings = dataclasses.replace(TINY, scan_topic="/base_scan")
    _refused(
        tmp_path,
        _tiny_drive(),
        settings,
        ros=ros,
        match=(
            r"no topic '/base_scan' \(--scan-topic\); its topics: /camera/image "
            r"\(sensor_msgs/msg/Image\), /odom \(nav_msgs/msg/Odometry\), /scan "
            r"\(sensor_msgs/msg/LaserScan\)"
        ),
    )


def test_unexpected_message_type_is_named(tmp_path):
    settings = dataclasses.replace(TINY, odom_topic=SCAN)
    _refused(
        tmp_path,
        _tiny_drive(),
        settings,
        match=r"topic '/scan' carries sensor_msgs/msg/LaserScan; expected nav_msgs/msg/Odom",
    )


def test_scan_whose_increment_disagrees_with_its_ranges(tmp_path):
    _refused(
        tmp_path,
        _tiny_drive(increment=0.1),
        match=r"/scan message 0: 5 ranges, but .* angle_increment 0.100000 rad give 32.4 beams",
    )


def test_images_of_changing_size(tmp_path):
    images = [
        np.zeros((4, 6, 3), np.uint8),
        np.zeros((4, 6, 3), np.uint8),
        np.zeros((5, 6, 3), np.uint8),
    ]
    _refused(
        tmp_path,
        _tiny_drive(images=images, t_image=np.array([0.25, 0.5, 0.75])),
        match=r"/camera/image message 2: image is 6x5, the earlier ones 6x4 \(images of changing",
    )


def test_timestamps_out_of_order(tmp_path):
    drive = _tiny_drive(
        t_scan=np.array([0.25, 0.75, 0.5]), scan_log_times=np.array([0.25, 0.5, 0.75])
    )
    _refused(
        tmp_path,
        drive,
        match=r"bad: /scan message 2: stamp .* is not after the previous message's .*out of order",
    )


def test_missing_bag_and_unreadable_bag(tmp_path):
    _refused(tmp_path, tmp_path / "nowhere.bag", match="no such bag")
    (tmp_path / "junk.bag").write_bytes(b"not a bag")
    _refused(tmp_path, tmp_path / "junk.bag", match="cannot be read as a ROS bag")


def test_existing_output_is_refused_unless_overwrite(sim_data, tmp_path):
    bag = write_bag(tmp_path / "drive", _drive(sim_data))
    import_rosbags([bag], tmp_path / "d", EVERY_SCAN, progress=False)
    with pytest.raises(FileExistsError, match="overwrite"):
        import_rosbags([bag], tmp_path / "d", EVERY_SCAN, progress=False)
    spaced = dataclasses.replace(EVERY_SCAN, min_travel=8.0, min_turn=10.0)
    import_rosbags([bag], tmp_path / "d", spaced, overwrite=True, progress=False)
    assert len(load_dataset(tmp_path / "d").sequences["drive"]) < 10
    assert sorted(p.name for p in tmp_path.iterdir()) == ["d", "drive"]
    (tmp_path / "other").mkdir()
    (tmp_path / "other" / "notes.txt").write_text("mine")
    with pytest.raises(FileExistsError, match="not empty; choose another directory$"):
        import_rosbags([bag], tmp_path / "other", EVERY_SCAN, overwrite=True, progress=False)


def test_cli_import(sim_data, tmp_path, capsys):
    from scripts.cli import main

    bag = write_bag(tmp_path / "drive.bag", _drive(sim_data), ros=1)
    args = [
        "import",
        "--rosbag",
        str(bag),
        "--scan-topic",
        SCAN,
        "--image-topic",
        IMAGE,
        "--odom-topic",
        ODOM,
        "--out",
        str(tmp_path / "d"),
        "--min-travel",
        "0",
        "--quiet",
    ]
    assert main(args) == 0
    assert len(load_dataset(tmp_path / "d").sequences["drive"]) == 10
    assert "10 frames" in capsys.readouterr().out
    bad = [a if a != SCAN else "/nope" for a in args]
    assert main([*bad[:-3], "--out", str(tmp_path / "e")]) == 2
    assert "no topic '/nope' (--scan-topic)" in capsys.readouterr().err
    assert not (tmp_path / "e").exists()


def test_image_messages_decode_to_rgb_or_are_refused():
    from types import SimpleNamespace

    from sim.readers.ros_messages import decode_image

    rgb = np.arange(2 * 3 * 3, dtype=np.uint8).reshape(2, 3, 3)
    padded = np.concatenate([rgb[..., ::-1].reshape(2, 9), np.zeros((2, 3), np.uint8)], axis=1)
    msg = SimpleNamespace(height=2, width=3, step=12, encoding="bgr8", data=padded.ravel())
    np.testing.assert_array_equal(decode_image(msg, "sensor_msgs/msg/Image", "m"), rgb)
    rgba = np.concatenate([rgb, np.full((2, 3, 1), 255, np.uint8)], axis=2)
    msg = SimpleNamespace(height=2, width=3, step=12, encoding="rgba8", data=rgba.ravel())
    np.testing.assert_array_equal(decode_image(msg, "sensor_msgs/msg/Image", "m"), rgb)
    msg.encoding = "16UC1"
    with pytest.raises(RosbagImportError, match=r"m: image encoding '16UC1' is not supported"):
        decode_image(msg, "sensor_msgs/msg/Image", "m")
    msg = SimpleNamespace(height=4, width=3, step=9, encoding="rgb8", data=rgb.ravel())
    with pytest.raises(RosbagImportError, match=r"18 bytes do not hold a 3x4 rgb8 image"):
        decode_image(msg, "sensor_msgs/msg/Image", "m")
    junk = SimpleNamespace(format="jpeg", data=np.arange(50, dtype=np.uint8))
    with pytest.raises(RosbagImportError, match=r"OpenCV cannot decode it \(format 'jpeg'\)"):
        decode_image(junk, "sensor_msgs/msg/CompressedImage", "m")


NAN_POSE = np.array([[np.nan, 0.0, 3.0], [2.0, 0.0, -3.0]])


@pytest.mark.parametrize(
    ("changes", "match"),
    [
        ({"poses": NAN_POSE}, r"message 0: odometry must be finite, got position \(nan, 0.0\)"),
        ({"velocities": np.array([[1.0, 0.5], [np.inf, 0.5]])}, r"message 1: .*linear.x inf"),
    ],
)
def test_non_finite_odometry_is_refused(tmp_path, changes, match):
    # NaN pose and infinite velocity were written into the dataset
    _refused(tmp_path, _tiny_drive(**changes), match=f"bad: /odom {match}")


def test_directory_that_is_no_ros2_bag(tmp_path):
    (tmp_path / "empty").mkdir()
    _refused(tmp_path, tmp_path / "empty", match="empty: a directory without metadata.yaml")
    bag = write_bag(tmp_path / "nometa", _tiny_drive())
    (bag / "metadata.yaml").unlink()
    _refused(tmp_path, bag, match="nometa: a directory without metadata.yaml")
    bag = write_bag(tmp_path / "nodata", _tiny_drive())
    for f in bag.iterdir():
        if f.name != "metadata.yaml":
            f.unlink()  # the storage files are gone: rosbags' FileNotFoundError
    _refused(tmp_path, bag, match="nodata: cannot be read as a ROS bag")


@pytest.mark.parametrize("beams", [360, 541, 720, 1081])
def test_angle_max_one_float32_increment_beyond_the_last_beam_is_accepted(beams):
    from types import SimpleNamespace

    from sim.readers.ros_messages import scan_geometry

    f = np.float32
    angle_min, inc = f(-np.pi), f(2 * np.pi / beams)
    msg = SimpleNamespace(
        ranges=np.ones(beams, np.float32),
        angle_min=angle_min,
        angle_increment=inc,
        angle_max=f(angle_min + f(beams) * inc),
        range_min=f(0.1),
        range_max=f(30.0),
    )
    assert scan_geometry(msg, "scan")[0] == beams  # the span: beams + 1.00001, not > beams + 1
    msg.angle_max = f(angle_min + f(beams + 1) * inc)
    with pytest.raises(RosbagImportError, match="give"):
        scan_geometry(msg, "scan")


def test_a_repeated_stamp_says_what_to_do(tmp_path):
    stamps, logged = np.array([0.25, 0.5, 0.5]), np.array([0.25, 0.5, 0.6])
    drive = _tiny_drive(t_scan=stamps, scan_log_times=logged)
    _refused(tmp_path, drive, match=r"/scan message 2: the same stamp .* write it again with full")
