"""Fuzzing the dataset reader: damaged copies of a small dataset (truncated and flipped
``.npz``, edited ``meta.json``, special numbers in every array, odd zip members and file names)
must give a DatasetError or a valid dataset, never another exception, a hang or non-finite
values. Seeded; about 500 cases in a few seconds."""

import json
import shutil
import warnings
import zipfile

import numpy as np
import pytest

from common.bounds import MAX_COORDINATE
from sim.dataset import DatasetError, load_dataset
from tests.sim.dataset_fixtures import sequence_arrays, write_dataset
from tests.sim.readers.fuzzing import SPECIAL_NUMBERS, budget, flipped, truncated

CASE_BUDGET_S = 2.0
META_VALUES = (
    True,
    False,
    None,
    -1,
    0,
    2,
    1.5,
    1e308,
    "x" * 300,
    "../x.npz",
    [],
    {},
    "2",
    10**400,
    -(10**400),
    1e4 + 1,
)


@pytest.fixture(scope="module")
def clean(tmp_path_factory):
    return write_dataset(tmp_path_factory.mktemp("clean"))


def _assert_valid(ds):
    for seq in ds.sequences.values():
        n = len(seq)
        for values in (seq.odometry, seq.times, seq.angles, seq.commands):
            assert np.isfinite(values).all()
        assert not np.isnan(seq.scans).any() and (seq.scans >= 0).all()
        assert (np.diff(seq.times) >= 0).all()
        assert seq.images.shape[1] > 0 and seq.images.shape[2] > 0 and seq.scans.shape[1] > 0
        assert seq.odometry.shape == (n, 3) and np.abs(seq.odometry[:, :2]).max() <= MAX_COORDINATE
        if seq.labels is not None:
            assert n == 0 or (seq.labels.min() >= -1 and seq.labels.max() < len(ds.manifolds))


def _load(path, kind, outcomes):
    with budget(CASE_BUDGET_S):
        try:
            ds = load_dataset(path, verify=False)  # past the checksum, to reach the parsing
        except DatasetError as err:
            outcomes[kind, "refused"] = outcomes.get((kind, "refused"), 0) + 1
            return err
    _assert_valid(ds)
    outcomes[kind, "read"] = outcomes.get((kind, "read"), 0) + 1
    return None


def _case(clean, tmp_path, case):
    path = tmp_path / f"case{case}"
    shutil.copytree(clean, path)
    return path


def test_damaged_files_give_a_dataset_error_or_a_valid_dataset(clean, tmp_path):
    rng = np.random.default_rng(11)
    npz, meta = (clean / "lawn-left.npz").read_bytes(), (clean / "meta.json").read_bytes()
    outcomes = {}
    for case in range(240):
        path = _case(clean, tmp_path, case)
        kind = ("truncated npz", "flipped npz", "flipped meta", "edited meta")[case % 4]
        if kind == "truncated npz":
            (path / "lawn-left.npz").write_bytes(truncated(npz, rng))
        elif kind == "flipped npz":
            (path / "lawn-left.npz").write_bytes(flipped(npz, rng, int(rng.integers(1, 4))))
        elif kind == "flipped meta":
            (path / "meta.json").write_bytes(flipped(meta, rng))
        else:
            _edit_meta(path / "meta.json", rng)
        err = _load(path, kind, outcomes)
        assert err is None or str(path) in str(err) or "lawn-left" in str(err), err
        shutil.rmtree(path)
    assert outcomes.get(("flipped npz", "refused"), 0) > 0
    assert outcomes.get(("edited meta", "refused"), 0) > 0


def _edit_meta(path, rng):
    meta = json.loads(path.read_text())
    entry = meta["sequences"]["lawn-left"]
    target = [meta, entry, meta["settings"]["laser"]][int(rng.integers(3))]
    key = list(target)[int(rng.integers(len(target)))]
    target[key] = META_VALUES[int(rng.integers(len(META_VALUES)))]
    path.write_text(json.dumps(meta))


def test_special_numbers_in_every_array_give_a_dataset_error_or_a_valid_dataset(tmp_path):
    rng = np.random.default_rng(12)
    outcomes = {}
    for case in range(200):
        arrays = sequence_arrays()
        key = sorted(arrays)[case % len(arrays)]
        a = arrays[key].reshape(-1)
        value = SPECIAL_NUMBERS[int(rng.integers(len(SPECIAL_NUMBERS)))]
        if key in ("labels", "images"):
            value = int(rng.choice([-5, -1, 0, 1, 2, 99, 255]))
            value = value % 256 if key == "images" else value
        with np.errstate(over="ignore"):  # 1e300 in a float32 array is inf
            a[int(rng.integers(a.size))] = value
        path = write_dataset(tmp_path / f"case{case}", arrays)
        _load(path, key, outcomes)
        shutil.rmtree(path)
    refused = {k for (k, outcome) in outcomes if outcome == "refused"}
    assert {"scans", "odometry", "times", "labels"} <= refused


def test_odd_zip_members_give_a_dataset_error_or_a_valid_dataset(clean, tmp_path):
    rng = np.random.default_rng(13)
    outcomes = {}
    names = ("images.npy", "../x.npy", "a/b.npy", "x.txt", "", "scans", "é.npy", "depth.npy")
    for case in range(60):
        path = _case(clean, tmp_path, case)
        with zipfile.ZipFile(path / "lawn-left.npz", "a") as zf, warnings.catch_warnings():
            warnings.simplefilter("ignore", UserWarning)  # zipfile: "Duplicate name"
            name = names[int(rng.integers(len(names)))] or "blank.npy"
            data = rng.bytes(int(rng.integers(0, 200)))
            if rng.random() < 0.5:  # a valid header, the wrong amount of data
                data = b"\x93NUMPY\x01\x00v\x00" + data
            zf.writestr(name, data)
        _load(path, "member", outcomes)
        shutil.rmtree(path)
    assert outcomes.get(("member", "refused"), 0) == 60  # every such member is refused
