"""Bags of a robot without a camera (laser and wheel odometry): imported as a dataset without
images, grouped by the laser; the methods on images say that the camera is missing."""

import dataclasses
import json
from types import SimpleNamespace

import numpy as np
import pytest

from mapping import ObservationGraphPartitioner
from sim.dataset import DatasetError, MissingSensorError, Sequence, load_dataset
from sim.readers.rosbag import ImportSettings, import_rosbags
from tests.sim.dataset_fixtures import sequence_arrays
from tests.sim.readers.rosbag_fixtures import IMAGE, ODOM, SCAN, drive_from_sequence, write_bag

WITH_CAMERA = ImportSettings(SCAN, IMAGE, ODOM, min_travel=0.0)
LASER_ONLY = dataclasses.replace(WITH_CAMERA, image_topic=None)


def _sequence(frames=12, beams=4):
    arrays = sequence_arrays(frames)
    rng = np.random.default_rng(5)
    arrays["scans"] = rng.uniform(1, 10, (frames, beams)).astype(np.float32)
    arrays["angles"] = np.linspace(-np.pi / 2, np.pi / 2, beams).astype(np.float32)
    arrays.pop("poses"), arrays.pop("labels")
    return Sequence(name="drive", world="office", **arrays)


def _without_camera(drive):
    return dataclasses.replace(drive, t_image=drive.t_image[:0], images=drive.images[:0])


@pytest.mark.parametrize("ros", [1, 2])
def test_a_laser_only_bag_imports_as_the_same_scans_without_images(tmp_path, ros):
    drive = drive_from_sequence(_sequence(), max_range=20.0)
    name = "drive.bag" if ros == 1 else "drive"
    (tmp_path / "cam").mkdir(), (tmp_path / "laser").mkdir()
    with_camera = write_bag(tmp_path / "cam" / name, drive, ros=ros)
    laser_only = write_bag(tmp_path / "laser" / name, _without_camera(drive), ros=ros)
    a = load_dataset(import_rosbags([with_camera], tmp_path / "a", WITH_CAMERA, progress=False))
    b = load_dataset(import_rosbags([laser_only], tmp_path / "b", LASER_ONLY, progress=False))
    assert a.has_camera and not b.has_camera
    sa, sb = a.sequences["drive"], b.sequences["drive"]
    assert sb.images is None and len(sb) == len(sa) == 12
    for key in ("scans", "angles", "odometry", "commands", "times"):
        np.testing.assert_array_equal(getattr(sb, key), getattr(sa, key))
    meta = json.loads((tmp_path / "b" / "meta.json").read_text())
    assert meta["camera"] is False and meta["settings"]["camera"] is None
    ra, rb = a.runs("robot"), b.runs("robot")
    assert rb.images is None and ra.images.shape[0] == 12
    groups = [
        ObservationGraphPartitioner().fit(r.scans, r.odometry, groups=r.groups).labels_
        for r in (ra, rb)
    ]
    np.testing.assert_array_equal(groups[0], groups[1])  # the same groups
    with pytest.raises(MissingSensorError, match="has no camera") as caught:
        b.concat("images")
    assert caught.value.sensor == "camera" and caught.value.path == b.path


def test_the_comparison_on_laser_only_drives_runs_the_methods_on_scans():
    from scripts.grouping.scores import compare_methods
    from sim.runs import Runs

    sequence = _sequence(40, 90)
    sequence.scans[20:] += 5.0  # two places: near walls, then far ones
    sequence.images = None  # no camera
    runs = Runs.from_sequences([sequence], 20.0)
    halves = (np.arange(len(runs)) >= len(runs) // 2).astype(int)
    model = SimpleNamespace(n_groups_=2, labels_=halves)  # a fitted partition's two fields
    keys = ("purity", "ari", "max_groups_per_manifold", "groups_per_manifold", "seconds")
    score = {"groups": model.n_groups_, "poses": "odometry", **dict.fromkeys(keys)}
    rows = compare_methods(runs, model, score)
    assert sorted(rows) == ["manifold/scans", "partition/scans"]


def test_images_in_a_dataset_without_a_camera_are_refused(tmp_path):
    drive = drive_from_sequence(_sequence(), max_range=20.0)
    bag = write_bag(tmp_path / "laser", _without_camera(drive))
    out = import_rosbags([bag], tmp_path / "d", LASER_ONLY, progress=False)
    meta = json.loads((out / "meta.json").read_text())
    meta["camera"] = "no"
    (out / "meta.json").write_text(json.dumps(meta))
    with pytest.raises(DatasetError, match="'camera' must be true or false"):
        load_dataset(out)


def test_image_topic_must_be_a_topic_or_none():
    with pytest.raises(ValueError, match=r"image_topic must be a non-empty string \(or None"):
        ImportSettings(SCAN, "", ODOM)
