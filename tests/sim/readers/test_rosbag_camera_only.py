"""Bags of a robot without a laser (camera and wheel odometry): imported as a dataset without
scans, written by rosbags' own writers (ROS 1, ROS 2 SQLite, ROS 2 MCAP) and compared with the
source. The grouping needs the laser and the methods on images the camera: each says which
sensor a dataset lacks, from the library and from the command line."""

import dataclasses
import json

import numpy as np
import pytest

from sim.dataset import DatasetError, MissingSensorError, Sequence, load_dataset
from sim.readers.rosbag import ImportSettings, RosbagImportError, import_rosbags
from tests.sim.dataset_fixtures import sequence_arrays
from tests.sim.readers.rosbag_fixtures import IMAGE, ODOM, SCAN, drive_from_sequence, write_bag

FULL = ImportSettings(SCAN, IMAGE, ODOM, world="lawn", min_travel=0.0)
CAMERA_ONLY = dataclasses.replace(FULL, scan_topic=None)
LASER_ONLY = dataclasses.replace(FULL, image_topic=None)
BAGS = {
    "ros1": ("drive.bag", 1, False),
    "ros2-sqlite3": ("drive", 2, False),
    "ros2-mcap": ("drive", 2, True),
}


def _sequence(frames=12, beams=5):
    arrays = sequence_arrays(frames)
    rng = np.random.default_rng(8)
    arrays["images"] = rng.integers(0, 256, (frames, 6, 8, 3), dtype=np.uint8)
    arrays["scans"] = rng.uniform(1, 10, (frames, beams)).astype(np.float32)
    arrays["angles"] = np.linspace(-np.pi / 2, np.pi / 2, beams).astype(np.float32)
    arrays.pop("poses"), arrays.pop("labels")
    return Sequence(name="drive", world="lawn", **arrays)


def _bag(tmp_path, kind="ros2-sqlite3", laser=True, camera=True, sequence=None):
    drive = drive_from_sequence(sequence or _sequence(), max_range=20.0)
    if not laser:
        drive = dataclasses.replace(drive, t_scan=drive.t_scan[:0], ranges=drive.ranges[:0])
    if not camera:
        drive = dataclasses.replace(drive, t_image=drive.t_image[:0], images=drive.images[:0])
    name, ros, mcap = BAGS[kind]
    folder = tmp_path / f"{kind}-{'laser' if laser else ''}-{'camera' if camera else ''}"
    folder.mkdir()
    return drive, write_bag(folder / name, drive, ros=ros, mcap=mcap)


def _interp(t, t_source, values):
    return np.column_stack([np.interp(t, t_source, c) for c in values.T])


@pytest.mark.parametrize("kind", sorted(BAGS))
def test_a_camera_only_bag_imports_as_its_images_and_odometry(tmp_path, kind):
    drive, bag = _bag(tmp_path, kind, laser=False)
    out = import_rosbags([bag], tmp_path / "data", CAMERA_ONLY, progress=False)
    data = load_dataset(out)
    assert data.has_camera and not data.has_laser and data.max_range is None
    meta = json.loads((out / "meta.json").read_text())
    assert meta["laser"] is False and meta["settings"]["laser"] is None
    got = data.sequences["drive"]
    # the images are the frames: each with odometry around it (none after the last odometry
    # message: nothing is extrapolated), bit-equal, at its own stamp
    t = drive.t_image[(drive.t_image >= drive.t_odom[0]) & (drive.t_image <= drive.t_odom[-1])]
    assert got.scans is None and got.angles is None and 0 < len(got) == len(t)
    np.testing.assert_array_equal(got.images, drive.images[: len(t)])
    np.testing.assert_allclose(got.times, t - t[0], atol=1e-9)
    # odometry and velocity interpolated at the image stamps between the odometry messages
    poses = _interp(
        t, drive.t_odom, np.column_stack([drive.poses[:, :2], np.unwrap(drive.poses[:, 2])])
    )
    np.testing.assert_allclose(got.odometry[:, :2], poses[:, :2], atol=1e-9)
    np.testing.assert_allclose(np.cos(got.odometry[:, 2] - poses[:, 2]), 1.0, atol=1e-12)
    np.testing.assert_allclose(got.commands, _interp(t, drive.t_odom, drive.velocities), atol=1e-9)
    assert np.array_equal(data.concat("images"), got.images)


def test_the_camera_only_import_of_a_full_bag_keeps_its_images(tmp_path):
    """A bag with a laser imported without it: the same images as the camera-only bag's."""
    _, full = _bag(tmp_path)
    _, camera_only = _bag(tmp_path, laser=False)
    a = load_dataset(import_rosbags([full], tmp_path / "a", CAMERA_ONLY, progress=False))
    b = load_dataset(import_rosbags([camera_only], tmp_path / "b", CAMERA_ONLY, progress=False))
    for key in ("images", "odometry", "commands", "times"):
        np.testing.assert_array_equal(
            getattr(a.sequences["drive"], key), getattr(b.sequences["drive"], key)
        )


def test_the_laser_is_missing_from_a_camera_only_dataset(tmp_path):
    _, bag = _bag(tmp_path, laser=False)
    data = load_dataset(import_rosbags([bag], tmp_path / "d", CAMERA_ONLY, progress=False))
    for call in (
        lambda: data.concat("scans"),
        lambda: data.concat("angles"),
        lambda: data.runs("lawn"),
    ):
        with pytest.raises(MissingSensorError, match="has no laser") as caught:
            call()
        assert caught.value.sensor == "laser" and caught.value.path == data.path
        assert str(data.path) in str(caught.value)


def test_the_grouping_refuses_a_dataset_without_a_laser(tmp_path, capsys):
    from scripts.cli import main
    from scripts.grouping.evaluate import evaluate_grouping

    _, bag = _bag(tmp_path, laser=False)
    data = load_dataset(import_rosbags([bag], tmp_path / "d", CAMERA_ONLY, progress=False))
    with pytest.raises(MissingSensorError, match=r"observation grouping \(group-eval\)"):
        evaluate_grouping(data, tmp_path / "out", progress=False)
    assert not (tmp_path / "out").exists()  # refused before anything is written
    args = ["group-eval", "--data", str(data.path), "--out", str(tmp_path / "cli"), "--quiet"]
    assert main(args) == 2
    err = capsys.readouterr().err
    assert f"{data.path} has no laser" in err and "Traceback" not in err


def test_the_methods_on_images_refuse_a_dataset_without_a_camera(tmp_path):
    from scripts.manifold.reproduce import feature_sets
    from servo.maps.build import build_map

    _, bag = _bag(tmp_path, camera=False)
    data = load_dataset(import_rosbags([bag], tmp_path / "d", LASER_ONLY, progress=False))
    for call in (
        lambda: data.concat("images"),
        lambda: feature_sets(data),
        lambda: build_map(data, "lawn"),
    ):
        with pytest.raises(MissingSensorError, match="has no camera") as caught:
            call()
        assert caught.value.sensor == "camera" and str(data.path) in str(caught.value)
    assert data.runs("lawn").images is None  # the grouping's input is there, without images


def test_cli_imports_a_camera_only_bag(tmp_path, capsys):
    from scripts.cli import main

    drive, bag = _bag(tmp_path, "ros1", laser=False)
    args = [
        "import",
        "--rosbag",
        str(bag),
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
    data = load_dataset(tmp_path / "d")
    assert f"drive: {len(data.sequences['drive'])} frames" in capsys.readouterr().out
    assert not data.has_laser and len(data.sequences["drive"]) >= len(drive.t_image) - 1
    neither = [a for a in args if a not in ("--image-topic", IMAGE)]
    assert main([*neither[:-5], "--out", str(tmp_path / "e"), "--quiet"]) == 2
    assert "scan_topic and image_topic are both None" in capsys.readouterr().err
    assert not (tmp_path / "e").exists()


def test_a_camera_only_bag_without_images_or_odometry_is_refused(tmp_path):
    _, bag = _bag(tmp_path, laser=False)
    with pytest.raises(RosbagImportError, match="no topic '/scan'"):
        import_rosbags([bag], tmp_path / "a", FULL, progress=False)
    slow = dataclasses.replace(CAMERA_ONLY, odom_max_gap=1e-4)  # odometry 0.01 s or more apart
    with pytest.raises(RosbagImportError, match="no image has odometry around it"):
        import_rosbags([bag], tmp_path / "b", slow, progress=False)


@pytest.mark.parametrize(
    ("meta", "arrays", "match"),
    [
        ({"laser": "no"}, {}, "'laser' must be true or false"),
        ({"laser": False, "camera": False}, {}, "'camera' and 'laser' are both false"),
        ({"laser": False}, {}, r"holds \['scans', 'angles'\] but meta.json says laser is false"),
        ({}, {"drop": ("scans",)}, r"arrays \['scans'\] missing"),
    ],
)
def test_the_laser_flag_is_checked_against_the_files(tmp_path, meta, arrays, match):
    from tests.sim.dataset_fixtures import write_dataset

    data = sequence_arrays()
    for key in arrays.get("drop", ()):
        data.pop(key)
    path = write_dataset(tmp_path / "d", data, **meta)
    with pytest.raises(DatasetError, match=match):
        load_dataset(path)


def test_a_dataset_without_a_laser_reads_without_scans_or_angles(tmp_path):
    from tests.sim.dataset_fixtures import write_dataset

    data = sequence_arrays()
    data.pop("scans"), data.pop("angles")
    path = write_dataset(tmp_path / "d", data, laser=False)
    got = load_dataset(path)
    assert not got.has_laser and got.sequences["lawn-left"].scans is None
    np.testing.assert_array_equal(got.concat("images"), data["images"])


def test_scan_topic_must_be_a_topic_or_none():
    with pytest.raises(ValueError, match=r"scan_topic must be a non-empty string \(or None"):
        ImportSettings("", IMAGE, ODOM)
    with pytest.raises(ValueError, match="give at least one of the two topics"):
        ImportSettings(None, None, ODOM)
