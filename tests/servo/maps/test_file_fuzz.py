"""Seeded fuzz of the servo map reader, as of every reader: truncated files, flipped bytes and
odd members (with both checksums recomputed, as other code would write them) raise
[`MapError`][servo.maps.types.MapError] naming the file, never a raw exception, within a time
budget."""

import json
import shutil

import numpy as np
import pytest

from servo.maps.file import load_map, meta_digest, save_map
from servo.maps.types import MapError
from sim.dataset import write_sequence
from tests.sim.readers.fuzzing import OverBudget, budget, flipped, truncated

CASES = 12  # per kind
ODD_VALUES = (
    None,
    True,
    -1,
    0,
    1e308,
    float("nan"),
    "x",
    "",
    [],
    [1, "a"],
    {},
    {"a": None},
    [[[[]]]],
    "9" * 400,
    10**400,
    -(10**400),
)
WORLD = "lawn:3"  # the small map of the session fixture generated_servo_map: quick to load


@pytest.fixture(scope="module")
def saved(generated_servo_map, tmp_path_factory):
    return save_map(generated_servo_map[0], tmp_path_factory.mktemp("fuzz-map"))


def _odd_array(a: np.ndarray, rng: np.random.Generator) -> np.ndarray:
    kind = int(rng.integers(8))
    if kind == 0:
        return a[:0]  # empty
    if kind == 1:
        return a.reshape(-1)  # another rank
    if kind == 2:
        return np.asarray(a.flat[0])  # 0-d
    if kind == 3:
        with np.errstate(invalid="ignore"):  # inf and NaN cast to integers: whatever comes
            return a.astype(np.float32 if a.dtype.kind in "iu" else np.int64)  # another kind
    if kind == 4:
        return np.full(a.shape, np.iinfo(np.int64).max if a.dtype.kind in "iu" else np.inf)
    if kind == 5:
        return np.full(a.shape, -1, np.int64 if a.dtype.kind in "iu" else a.dtype)
    if kind == 6:
        return a.astype("<U3")  # text
    return a.astype(bool)


def _variants(saved, rng):
    """``(kind, json bytes, npz bytes)`` of damaged copies of the map."""
    json_bytes = saved.read_bytes()
    npz_bytes = saved.with_suffix(".npz").read_bytes()
    meta = json.loads(json_bytes)
    with np.load(saved.with_suffix(".npz")) as f:
        arrays = {k: f[k] for k in f.files}
    for _ in range(CASES):
        yield "truncated json", truncated(json_bytes, rng), npz_bytes
        yield "truncated npz", json_bytes, truncated(npz_bytes, rng)
        yield "flipped json", flipped(json_bytes, rng, int(rng.integers(1, 4))), npz_bytes
        yield "flipped npz", json_bytes, flipped(npz_bytes, rng, int(rng.integers(1, 4)))
        # an odd member of the description, both checksums recomputed
        odd = json.loads(json_bytes)
        target, keys = odd, sorted(meta)
        key = keys[int(rng.integers(len(keys)))]
        while isinstance(target[key], dict) and target[key] and rng.random() < 0.6:
            target = target[key]
            inner = sorted(target)
            key = inner[int(rng.integers(len(inner)))]
        target[key] = ODD_VALUES[int(rng.integers(len(ODD_VALUES)))]
        odd["meta_sha256"] = meta_digest(odd)
        yield f"odd member {key}", json.dumps(odd).encode(), npz_bytes
        # an odd array, or one missing or extra, both checksums recomputed
        forged = dict(arrays)
        names = sorted(forged)
        name = names[int(rng.integers(len(names)))]
        choice = rng.random()
        if choice < 0.15:
            del forged[name]
        elif choice < 0.25:
            forged["extra"] = np.zeros(3)
        else:
            forged[name] = _odd_array(forged[name], rng)
        yield f"odd array {name}", forged, meta


@pytest.mark.parametrize("seed", [0, 1])
def test_a_damaged_map_raises_a_map_error(saved, tmp_path, seed):
    rng = np.random.default_rng(seed)
    escaped = []
    for i, (kind, first, second) in enumerate(_variants(saved, rng)):
        path = tmp_path / f"{i}" / saved.name
        path.parent.mkdir()
        if isinstance(first, dict):  # forged arrays: the files as other code would write them
            meta = dict(second)
            meta["sha256"] = write_sequence(path.with_suffix(".npz"), first)
            meta["meta_sha256"] = meta_digest(meta)
            path.write_text(json.dumps(meta))
        else:
            path.write_bytes(first)
            path.with_suffix(".npz").write_bytes(second)
        try:
            with budget(30):
                load_map(path, WORLD)
        except MapError as err:
            assert str(path.parent) in str(err), f"{kind}: the error names no file: {err}"
        except OverBudget:
            escaped.append(f"{kind}: over budget")
        except Exception as err:  # what the fuzz looks for
            escaped.append(f"{kind}: {type(err).__name__}: {err}"[:300])
        shutil.rmtree(path.parent)
    assert not escaped, "\n".join(escaped)
