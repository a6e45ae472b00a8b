"""The harness on the dataset reader: sequence files and ``meta.json`` damaged (truncated,
flipped, odd members and arrays of another dtype, shape or rank, special numbers, huge
integers), sequences that disagree with one another or with the settings, one file under two
names, labels beyond the manifolds, special files and compression bombs; every checksum
recomputed after the edit. Each gives a DatasetError naming the folder or a valid dataset."""

import json
import os
import shutil

import numpy as np
import pytest

from common import npz
from common.bounds import MAX_COORDINATE, MAX_RANGE
from sim.dataset import DatasetError, file_sha256, load_dataset, write_sequence
from tests.fuzz.harness import (
    SPECIAL_FILES,
    Judge,
    case_count,
    flipped,
    odd_array,
    odd_member,
    special_file,
    truncated,
)
from tests.sim.dataset_fixtures import sequence_arrays, write_dataset

KINDS = (
    "array",
    "meta",
    "truncated",
    "flipped",
    "beams",
    "image size",
    "angles",
    "world",
    "file twice",
    "labels",
    "no manifolds",
    "max range",
    "special file",
    "bomb",
    "settings",
)
CAP = 1 << 20  # the arrays' bytes read per file during the fuzz


@pytest.fixture(scope="module")
def clean(tmp_path_factory):
    """Two sequences of one world, with the settings a collection records."""
    path = write_dataset(tmp_path_factory.mktemp("clean"))
    write_sequence(path / "lawn-right.npz", sequence_arrays())
    meta = json.loads((path / "meta.json").read_text())
    meta["sequences"]["lawn-right"] = dict(
        meta["sequences"]["lawn-left"],
        file="lawn-right.npz",
        sha256=file_sha256(path / "lawn-right.npz"),
    )
    meta["settings"] = {
        "laser": {"max_range": 10.0, "beams": 4, "fov": np.pi},
        "camera": {"width": 6, "height": 4},
        "worlds": ["lawn"],
    }
    (path / "meta.json").write_text(json.dumps(meta))
    assert len(load_dataset(path).sequences) == 2
    return path


def _valid(ds):
    """The loaded dataset holds what a robot can record, consistently."""
    seqs = list(ds.sequences.values())
    for seq in seqs:
        n = len(seq)
        for values in (seq.odometry, seq.times, seq.commands):
            assert np.isfinite(values).all(), f"{seq.name}: non-finite values"
        assert seq.odometry.shape == (n, 3) and np.abs(seq.odometry[:, :2]).max() <= MAX_COORDINATE
        assert (np.diff(seq.times) >= 0).all(), f"{seq.name}: time goes back"
        if seq.scans is not None:
            assert seq.scans.ndim == 2 and seq.scans.shape == (n, len(seq.angles))
            assert seq.scans.dtype.kind == "f" and not np.isnan(seq.scans).any()
            assert (seq.scans >= 0).all() and np.isfinite(seq.angles).all()
        if seq.images is not None:
            assert seq.images.dtype == np.uint8 and seq.images.ndim == 4
        if seq.depth is not None:
            assert seq.depth.dtype.kind == "f" and seq.depth.shape == seq.images.shape[:3]
        if seq.labels is not None and n:
            assert seq.labels.min() >= -1 and seq.labels.max() < len(ds.manifolds), "labels"
    for seq in seqs[1:]:
        assert seq.scans is None or seq.scans.shape[1] == seqs[0].scans.shape[1], "beams differ"
        assert seq.images is None or seq.images.shape[1:] == seqs[0].images.shape[1:], "images"
    files = [ds.meta["sequences"][name]["file"] for name in ds.sequences]
    assert len(set(files)) == len(files), "one file under two names"
    assert ds.max_range is None or 0 < ds.max_range <= MAX_RANGE, f"max_range {ds.max_range}"
    for field in ("odometry", "times", "scans", "images"):
        if getattr(seqs[0], field, None) is not None:
            ds.concat(field)


def _write(path, name, arrays, meta):
    """Write a sequence and record its new checksum and frame count in ``meta``."""
    file = path / meta["sequences"][name]["file"]
    if file.is_symlink() or file.exists():
        file.unlink()
    meta["sequences"][name]["sha256"] = write_sequence(file, arrays)


def _case(clean, path, kind, rng, case):
    shutil.copytree(clean, path)
    meta = json.loads((path / "meta.json").read_text())
    name = ("lawn-left", "lawn-right")[case % 2]
    file = path / f"{name}.npz"
    arrays = sequence_arrays()
    if kind == "array":
        key = sorted(arrays)[int(rng.integers(len(arrays)))]
        _, arrays[key] = odd_array(arrays[key], rng)
        if rng.random() < 0.2:
            arrays["depth"] = odd_array(np.ones((5, 4, 6), np.float32), rng)[1]
        _write(path, name, arrays, meta)
    elif kind == "meta":
        odd_member(meta, rng)
    elif kind in ("truncated", "flipped"):
        data = file.read_bytes()
        file.write_bytes(truncated(data, rng) if kind == "truncated" else flipped(data, rng, 2))
        meta["sequences"][name]["sha256"] = file_sha256(file)
    elif kind in ("beams", "angles"):
        beams = 4 if kind == "angles" else int(rng.choice([3, 5, 61]))
        arrays["scans"] = np.full((5, beams), 2.0, np.float32)
        arrays["angles"] = np.linspace(-1.0, 1.0, beams).astype(np.float32)
        _write(path, name, arrays, meta)
    elif kind == "image size":
        arrays["images"] = np.zeros((5, 4 + int(rng.integers(1, 3)), 6, 3), np.uint8)
        _write(path, name, arrays, meta)
    elif kind == "world":
        meta["sequences"][name]["world"] = str(rng.choice(["hallway", "lawn:3", "x", "../lawn"]))
    elif kind == "file twice":
        meta["sequences"][name] = dict(meta["sequences"]["lawn-left" if case % 2 else "lawn-right"])
    elif kind == "labels":
        arrays["labels"] = np.full(5, int(rng.choice([2, 7, 999, -2, 32767])), np.int16)
        _write(path, name, arrays, meta)
    elif kind == "no manifolds":
        del meta["manifolds"]
        if rng.random() < 0.5:
            arrays["labels"] = np.full(5, 999, np.int16)
            _write(path, name, arrays, meta)
    elif kind == "max range":
        meta["settings"]["laser"]["max_range"] = rng.choice([1e300, 10**400, -1, 0, "10", None])
    elif kind == "special file":
        target = file if rng.random() < 0.6 else path / "meta.json"
        special_file(target, SPECIAL_FILES[case % len(SPECIAL_FILES)])
        if target.name == "meta.json":
            return
    elif kind == "bomb":  # a member of zeros well beyond the cap, a small file
        arrays["images"] = np.zeros((5, 4, 6 * int(rng.integers(20000, 60000)), 3), np.uint8)
        _write(path, name, arrays, meta)
        meta["sequences"][name]["frames"] = 5
    else:  # settings that contradict the arrays
        key = str(rng.choice(["beams", "fov", "width", "height", "worlds", "camera"]))
        value = int(rng.choice([3, 5, 361, 10**400]))
        if key == "beams":
            meta["settings"]["laser"]["beams"] = value
        elif key in ("fov", "camera"):
            odd = (1.0, 2 * np.pi, -np.pi, 7.0, float("nan"), 10**400, True, "3.14")
            section = meta["settings"]["laser" if key == "fov" else "camera"]
            meta["settings"]["laser" if key == "fov" else "camera"] = (
                dict(section, fov=odd[int(rng.integers(len(odd)))])
                if key == "fov"
                else odd[int(rng.integers(len(odd)))]
            )
        elif key == "worlds":
            meta["settings"]["worlds"] = ["hallway"]
        else:
            meta["settings"]["camera"][key] = value
    (path / "meta.json").write_text(json.dumps(meta))


@pytest.mark.parametrize("seed", [0, 1])
def test_every_kind_of_damage_gives_a_dataset_error_or_a_valid_dataset(
    clean, tmp_path, monkeypatch, seed
):
    monkeypatch.setattr(npz, "MAX_ARRAY_BYTES", CAP)
    rng = np.random.default_rng(200 + seed)
    judge = Judge(load_dataset, DatasetError, _valid, seconds=5.0)
    n = case_count(70) // 2
    for case in range(n):
        kind = KINDS[case % len(KINDS)]
        path = tmp_path / f"case{case}"
        _case(clean, path, kind, rng, case)
        judge(kind, path)
        shutil.rmtree(path)
    judge.assert_clean(least=n)
    assert judge.outcomes["bomb", "refused"] > 0


def test_a_sequence_file_linked_to_dev_zero_is_refused_without_reading(clean, tmp_path):
    path = tmp_path / "d"
    shutil.copytree(clean, path)
    os.remove(path / "lawn-left.npz")
    special_file(path / "lawn-left.npz", "link to /dev/zero")
    with pytest.raises(DatasetError, match=r"lawn-left.npz is no regular file"):
        load_dataset(path)
