"""A dataset's sequences agree with one another and with the settings, members have the form
of the format (``depth`` included), labels are checked whenever there are labels, one file is
one sequence, and the maximum range has the bound of every reader: each refused with a
DatasetError naming the file or folder, never a raw numpy error later in ``concat``."""

import json
import os

import numpy as np
import pytest

from sim.dataset import DatasetError, load_dataset, write_sequence
from sim.dataset.consistency import ANGLE_TOLERANCE
from tests.sim.dataset_fixtures import sequence_arrays, write_dataset
from tests.sim.readers.fuzzing import budget


def _two_sequences(tmp_path, second: dict, **meta_changes):
    """A dataset of ``lawn-left`` (valid) and ``lawn-right`` (valid arrays changed by
    ``second``)."""
    d = write_dataset(tmp_path / "d", **meta_changes)
    meta = json.loads((d / "meta.json").read_text())
    arrays = {**sequence_arrays(), **second}
    digest = write_sequence(d / "lawn-right.npz", arrays)
    meta["sequences"]["lawn-right"] = {
        "file": "lawn-right.npz",
        "world": "lawn",
        "frames": len(arrays["times"]),
        "sha256": digest,
    }
    (d / "meta.json").write_text(json.dumps(meta))
    return d


def _angles(beams):
    return np.linspace(-np.pi / 2, np.pi / 2, beams).astype(np.float32)


@pytest.mark.parametrize(
    ("second", "match"),
    [
        (
            {"scans": np.ones((5, 6), np.float32), "angles": _angles(6)},
            r"lawn-right.npz\): 6 beams, but sequence 'lawn-left' has 4",
        ),
        ({"angles": _angles(4) * 0.5}, r"beam angles differ from sequence 'lawn-left'"),
        (
            {"images": np.zeros((5, 8, 6, 3), np.uint8)},
            r"images of shape \(8, 6, 3\), but sequence 'lawn-left' has \(4, 6, 3\)",
        ),
    ],
)
def test_sequences_that_disagree_are_refused(tmp_path, second, match):
    d = _two_sequences(tmp_path, second)
    with pytest.raises(DatasetError, match=match) as err:
        load_dataset(d)
    assert str(d) in str(err.value)


def test_angles_within_the_tolerance_are_the_same_beams(tmp_path):
    d = _two_sequences(tmp_path, {"angles": _angles(4) + np.float32(ANGLE_TOLERANCE / 4)})
    assert load_dataset(d).concat("scans").shape == (10, 4)


@pytest.mark.parametrize(
    ("settings", "match"),
    [
        ({"laser": {"max_range": 10.0, "beams": 361}}, "4 beams, but meta.json's settings"),
        (
            {"laser": {"max_range": 10.0}, "camera": {"width": 320, "height": 240}},
            "images of 6x4, but meta.json's settings.camera is 320x240",
        ),
        (
            {"laser": {"max_range": 10.0}, "worlds": ["hallway"]},
            r"world 'lawn' is not among meta.json's settings.worlds \['hallway'\]",
        ),
        (
            {"laser": {"max_range": 10.0, "fov": 1.0}},
            r"beam angles span 3.14159 rad, but meta.json's settings.laser.fov is 1 rad",
        ),
    ],
)
def test_settings_that_contradict_the_arrays_are_refused(tmp_path, settings, match):
    d = write_dataset(tmp_path / "d", settings=settings)
    with pytest.raises(DatasetError, match=match) as err:
        load_dataset(d)
    assert "lawn-left.npz" in str(err.value)


def test_settings_that_agree_are_read(tmp_path):
    settings = {
        "laser": {"max_range": 10.0, "beams": 4, "fov": np.pi},
        "camera": {"width": 6, "height": 4},
        "worlds": ["lawn"],
    }
    assert len(load_dataset(write_dataset(tmp_path / "d", settings=settings)).sequences) == 1


def test_an_imported_scan_of_decreasing_angles_records_a_negative_span(tmp_path):
    arrays = sequence_arrays()
    arrays["angles"] = arrays["angles"][::-1].copy()
    settings = {"laser": {"max_range": 10.0, "fov": -float(np.pi)}}
    assert load_dataset(write_dataset(tmp_path / "d", arrays, settings=settings)).sequences


def test_a_full_turn_spans_one_beam_less_than_its_field_of_view(tmp_path):
    from sim.laser import LaserConfig

    arrays = sequence_arrays()
    arrays["angles"] = LaserConfig(fov=2 * np.pi, beams=4).angles.astype(np.float32)
    settings = {"laser": {"max_range": 10.0, "fov": 2 * np.pi}}
    assert load_dataset(write_dataset(tmp_path / "d", arrays, settings=settings)).sequences


@pytest.mark.parametrize("fov", [-7.0, 7.0, 10**400, float("nan")])
def test_a_field_of_view_beyond_a_full_turn_is_refused(tmp_path, fov):
    d = write_dataset(tmp_path / "d", settings={"laser": {"max_range": 10.0, "fov": fov}})
    with pytest.raises(
        DatasetError,
        match=r"meta.json: settings.laser.fov must be a field of "
        r"view of at most 2 pi rad",
    ):
        load_dataset(d)


def test_one_file_under_two_names_is_refused(tmp_path):
    d = write_dataset(tmp_path / "d")
    meta = json.loads((d / "meta.json").read_text())
    meta["sequences"]["lawn-again"] = dict(meta["sequences"]["lawn-left"])
    (d / "meta.json").write_text(json.dumps(meta))
    with pytest.raises(DatasetError, match="'lawn-left' and 'lawn-again' both name the file"):
        load_dataset(d)


def test_labels_without_manifolds_are_refused(tmp_path):
    arrays = {**sequence_arrays(), "labels": np.full(5, 999, np.int16)}
    d = write_dataset(tmp_path / "d", arrays)
    meta = json.loads((d / "meta.json").read_text())
    with pytest.raises(DatasetError, match=r"labels from 999 to 999"):
        load_dataset(d)
    del meta["manifolds"]
    (d / "meta.json").write_text(json.dumps(meta))
    with pytest.raises(DatasetError, match="have labels .* but there is no 'manifolds'") as err:
        load_dataset(d)
    assert str(d / "meta.json") in str(err.value)


@pytest.mark.parametrize("max_range", [1e300, 10**400, 0, -1.0, True])
def test_a_maximum_range_beyond_the_bound_is_refused(tmp_path, max_range):
    d = write_dataset(tmp_path / "d", settings={"laser": {"max_range": max_range}})
    with pytest.raises(DatasetError, match=r"max_range' must be a number of metres in \(0, 1"):
        load_dataset(d)


@pytest.mark.parametrize(
    ("depth", "match"),
    [
        (np.full((5, 4, 6), "1.0"), r"depth has dtype <U3, expected float32"),
        (np.ones((5, 4, 6), np.complex64), "depth has dtype complex64"),
        (np.ones((5, 4, 6), "datetime64[s]"), r"depth has dtype datetime64\[s\]"),
        (np.ones((5, 4), np.float32), r"depth has shape \(5, 4\); expected \(frames, \*, \*\)"),
        (np.ones((5, 4, 6, 1), np.float32), r"depth has shape \(5, 4, 6, 1\)"),
        (np.ones((5, 3, 6), np.float32), r"depth has shape \(5, 3, 6\); expected \(frames, 4, 6\)"),
        (np.ones((4, 4, 6), np.float32), r"depth has shape \(4, 4, 6\), meta says 5 frames"),
        (np.full((5, 4, 6), np.nan, np.float32), "depth holds NaN"),
    ],
)
def test_a_depth_member_of_another_form_is_refused_naming_the_file(tmp_path, depth, match):
    d = write_dataset(tmp_path / "d", {**sequence_arrays(), "depth": depth})
    with pytest.raises(DatasetError, match=match) as err:
        load_dataset(d)
    assert str(d / "lawn-left.npz") in str(err.value)


def test_a_depth_member_of_the_format_is_read(tmp_path):
    depth = np.full((5, 4, 6), 2.5, np.float32)
    ds = load_dataset(write_dataset(tmp_path / "d", {**sequence_arrays(), "depth": depth}))
    assert ds.sequences["lawn-left"].depth.shape == (5, 4, 6)


@pytest.mark.parametrize("member", ["meta.json", "lawn-left.npz"])
def test_special_files_are_refused_without_blocking(tmp_path, member):
    d = write_dataset(tmp_path / "d")
    (d / member).unlink()
    os.mkfifo(d / member)
    with budget(5), pytest.raises(DatasetError, match="is no regular file") as err:
        load_dataset(d)
    assert str(d) in str(err.value)
    (d / member).unlink()
    (d / member).symlink_to("/dev/zero")
    with budget(5), pytest.raises(DatasetError, match="is no regular file"):
        load_dataset(d)


def _random_change(rng) -> tuple[dict, dict]:
    """(arrays of the second sequence, meta changes): one change, or none, at random."""
    frames = int(rng.integers(1, 7))
    arrays = sequence_arrays(frames)
    beams = int(rng.integers(1, 7))
    kind = int(rng.integers(6))
    if kind == 0:
        arrays["scans"] = np.ones((frames, beams), np.float32)
        arrays["angles"] = _angles(beams)
    elif kind == 1:
        arrays["angles"] = arrays["angles"] + np.float32(rng.choice([1e-7, 1e-3, 0.1]))
    elif kind == 2:
        arrays["images"] = np.zeros((frames, int(rng.integers(1, 6)), 6, 3), np.uint8)
    elif kind == 3:
        arrays["depth"] = np.ones((frames, *rng.integers(3, 7, 2)), np.float32)
    settings = {"laser": {"max_range": 10.0}}
    if rng.random() < 0.3:
        settings["laser"]["beams"] = int(rng.choice([4, beams]))
    if rng.random() < 0.3:
        settings["worlds"] = [str(rng.choice(["lawn", "hallway"]))]
    return arrays, {"settings": settings}


def test_random_disagreements_give_a_dataset_error_or_a_dataset_that_concatenates(tmp_path):
    rng = np.random.default_rng(5)
    outcomes = {"refused": 0, "read": 0}
    for case in range(60):
        arrays, meta = _random_change(rng)
        d = _two_sequences(tmp_path / f"case{case}", arrays, **meta)
        with budget(5):
            try:
                ds = load_dataset(d)
            except DatasetError as err:
                assert str(d) in str(err), err
                outcomes["refused"] += 1
                continue
        for field in ("images", "scans", "angles", "odometry", "commands", "times", "labels"):
            ds.concat(field)  # what broke with a raw numpy error before
        first = ds.sequences["lawn-left"]
        for s in ds.sequences.values():
            assert s.scans.shape[1] == len(first.angles) and s.images.shape[1:] == (4, 6, 3)
        outcomes["read"] += 1
    assert outcomes["refused"] > 10 and outcomes["read"] > 10, outcomes


@pytest.mark.parametrize("camera", [True, 3, "320x240", [320, 240]])
def test_camera_settings_that_are_no_object_are_refused(tmp_path, camera):
    d = write_dataset(tmp_path / "d", settings={"laser": {"max_range": 10.0}, "camera": camera})
    with pytest.raises(DatasetError, match=r"meta.json: 'settings.camera' must be an object"):
        load_dataset(d)
