"""The harness on the servo map reader: the description and the arrays damaged (truncated,
flipped, odd members at any depth, huge integers, arrays of another dtype, shape or rank,
NaN or far-off poses, negative frames, indices beyond the names), a bomb of zeros and special
files in place of either file; both checksums recomputed after every edit. Each gives a
MapError naming the map or a map whose every index and pose is possible."""

import json
import shutil

import numpy as np
import pytest

from common import npz
from common.bounds import MAX_COORDINATE
from servo.maps.file import load_map, meta_digest, save_map
from servo.maps.types import MapError
from sim.dataset import write_sequence
from tests.fuzz.harness import (
    ODD_VALUES,
    SPECIAL_FILES,
    Judge,
    case_count,
    flipped,
    odd_array,
    odd_member,
    special_file,
    truncated,
)

WORLD = "lawn:3"  # the small map of the session fixture generated_servo_map
KINDS = ("member", "array", "array", "index", "truncated", "flipped", "special file", "bomb")
CAP = 8 << 20  # the arrays' bytes read per file during the fuzz (the map holds ~1 MB)


@pytest.fixture(scope="module")
def saved(generated_servo_map, tmp_path_factory):
    return save_map(generated_servo_map[0], tmp_path_factory.mktemp("fuzz-map"))


def _valid(m) -> None:
    n = len(m.frame)
    assert np.isfinite(m.poses).all() and np.isfinite(m.true_poses).all(), "non-finite pose"
    assert np.abs(m.true_poses[:, :2]).max() <= MAX_COORDINATE, "far-off true pose"
    assert (m.frame >= 0).all(), "negative frame"
    assert ((m.sequence >= 0) & (m.sequence < len(m.sequence_names))).all(), "sequence index"
    assert ((m.clusters >= 0) & (m.clusters < len(m.clustering.centers_))).all(), "clusters"
    assert ((m.edges >= 0) & (m.edges < n)).all(), "edges"
    assert m.images.dtype == np.uint8 and not np.isnan(m.scans).any(), "images or scans"
    assert 0 < m.max_range <= 1e4, f"max_range {m.max_range}"


def _write(path, meta, arrays):
    """The files as other code would write them: both checksums recomputed."""
    meta = dict(meta)
    meta["sha256"] = write_sequence(path.with_suffix(".npz"), arrays)
    meta["meta_sha256"] = meta_digest(meta)
    path.write_text(json.dumps(meta))


def _case(path, saved, kind, rng, case):
    meta = json.loads(saved.read_text())
    with np.load(saved.with_suffix(".npz")) as f:
        arrays = {k: f[k] for k in f.files}
    if kind == "member":
        odd_member(meta, rng, ODD_VALUES)
    elif kind == "array":
        name = sorted(arrays)[int(rng.integers(len(arrays)))]
        _, arrays[name] = odd_array(arrays[name], rng)
    elif kind == "index":  # one value no map can hold
        name, value = [
            ("true_poses", np.nan),
            ("true_poses", 1e300),
            ("poses", -np.inf),
            ("frame", -3),
            ("sequence", 7),
            ("sequence", -1),
            ("clusters", 99),
            ("edges", 10**6),
            ("true_labels", 99),
            ("scans", np.nan),
            ("angles", 1e9),
        ][int(rng.integers(11))]
        a = arrays[name].copy()
        a.flat[int(rng.integers(a.size))] = value
        arrays[name] = a
    elif kind == "bomb":
        arrays["images"] = np.zeros((len(arrays["frame"]), 400, 400, 3), np.uint8)
    _write(path, meta, arrays)
    if kind in ("truncated", "flipped"):
        target = path if rng.random() < 0.5 else path.with_suffix(".npz")
        data = target.read_bytes()
        target.write_bytes(truncated(data, rng) if kind == "truncated" else flipped(data, rng))
        if target == path.with_suffix(".npz"):  # the npz's checksum recomputed as well
            from sim.dataset import file_sha256

            meta["sha256"] = file_sha256(target)
            meta["meta_sha256"] = meta_digest(meta)
            path.write_text(json.dumps(meta))
    elif kind == "special file":
        target = path if case % 2 else path.with_suffix(".npz")
        special_file(target, SPECIAL_FILES[case // 2 % len(SPECIAL_FILES)])


@pytest.mark.parametrize("seed", [0, 1])
def test_every_kind_of_damage_gives_a_map_error_or_a_possible_map(
    saved, tmp_path, monkeypatch, seed
):
    monkeypatch.setattr(npz, "MAX_ARRAY_BYTES", CAP)
    rng = np.random.default_rng(400 + seed)
    judge = Judge(lambda p: load_map(p, WORLD), MapError, _valid, seconds=10.0)
    n = case_count(40) // 2  # a case writes and loads a map of 1 MB: ~0.3 s
    for case in range(n):
        kind = KINDS[case % len(KINDS)]
        path = tmp_path / f"{case}" / saved.name
        path.parent.mkdir()
        _case(path, saved, kind, rng, case)
        judge(kind, path, names=path.with_suffix(""))  # the .json or the .npz
        shutil.rmtree(path.parent)
    judge.assert_clean(least=n)
    assert judge.outcomes["bomb", "refused"] > 0
