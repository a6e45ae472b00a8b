"""Values a servo map file may not hold, each refused with a MapError naming the file and the
field even when both checksums match (as other code would write them): NaN or far-off poses,
negative frames, sequences beyond the names, a maximum range of 400 digits or beyond the bound
of every reader, a scalar where an estimator keeps an array; and no special file is opened."""

import json
import os
import shutil
from pathlib import Path

import numpy as np
import pytest

from servo.maps.file import load_map
from servo.maps.types import MapError
from tests.servo.maps.test_file import _edit, _forge  # the map file tests' own forgers
from tests.sim.readers.fuzzing import budget

WORLD = "lawn:3"  # the map of the session fixture generated_servo_map


@pytest.fixture
def copy(generated_servo_map, tmp_path) -> Path:
    """A private copy of the generated map to damage; its .json path."""
    _, cache = generated_servo_map
    for path in cache.iterdir():
        shutil.copy(path, tmp_path / path.name)
    return next(tmp_path.glob("*.json"))


@pytest.mark.parametrize(
    ("name", "change", "match"),
    [
        ("true_poses", lambda a: np.full_like(a, np.nan), "true_poses position holds NaN"),
        ("true_poses", lambda a: a + 1e300, "true_poses position .* beyond the bound"),
        ("poses", lambda a: np.full_like(a, np.inf), "poses position holds NaN or infinity"),
        ("frame", lambda a: np.full_like(a, -3), r"frame must be >= 0"),
        ("sequence", lambda a: np.full_like(a, 7), r"sequence must lie in \[0, \d+\)"),
        ("angles", lambda a: a * 100, "angles .* beyond the bound"),
        ("scans", lambda a: np.full_like(a, 1e20), "scans .* beyond the bound of 10000 m"),
    ],
)
def test_impossible_arrays_are_refused_naming_the_file(copy, name, change, match):
    _forge(copy, name, change)
    with pytest.raises(MapError, match=match) as err:
        load_map(copy, WORLD)
    assert str(copy.parent) in str(err.value)


@pytest.mark.parametrize(
    ("change", "match"),
    [
        (lambda m: m.update(max_range=10**400), r"max_range must be .* got 1000"),
        (lambda m: m.update(max_range=1e300), r"max_range must be a number of metres in \(0, "),
        (lambda m: m.update(max_range=True), "max_range must be"),
        (
            lambda m: m["clustering"]["records"]["_models"]["items"][0].update(
                degrees={"value": True}
            ),
            r"degrees must be an array",
        ),
    ],
)
def test_impossible_descriptions_are_refused_naming_the_file(copy, change, match):
    _edit(copy, change)
    with pytest.raises(MapError, match=match) as err:
        load_map(copy, WORLD)
    assert str(copy) in str(err.value)


def test_the_untouched_copy_loads(copy):
    assert load_map(copy, WORLD).world == WORLD


@pytest.mark.parametrize("member", [".json", ".npz"])
def test_special_files_are_refused_without_blocking(copy, member):
    path = copy.with_suffix(member)
    path.unlink()
    os.mkfifo(path)
    with budget(5), pytest.raises(MapError) as err:
        load_map(copy, WORLD)
    assert str(copy.parent) in str(err.value)
    path.unlink()
    path.symlink_to("/dev/zero")
    with budget(5), pytest.raises(MapError):
        load_map(copy, WORLD)


ODD_VALUES = (True, -3, 7, 10**400, -(10**400), 1e300, float("nan"), None, "x", [], {})


def _leaves(obj, where=()):
    """Every member path of a description, and for each ``{'array': key}`` the same path with
    a scalar put in its place."""
    if isinstance(obj, dict):
        for k, v in obj.items():
            if k != "meta_sha256":
                yield (*where, k)
                yield from _leaves(v, (*where, k))
    elif isinstance(obj, list):
        for i, v in enumerate(obj[:2]):
            yield (*where, i)
            yield from _leaves(v, (*where, i))


def test_odd_members_at_any_depth_are_map_errors(copy):
    rng = np.random.default_rng(0)
    meta = json.loads(copy.read_text())
    leaves = list(_leaves(meta))
    escaped = []
    for _ in range(60):
        where = leaves[int(rng.integers(len(leaves)))]
        odd = ODD_VALUES[int(rng.integers(len(ODD_VALUES)))]
        value = {"value": odd} if rng.random() < 0.5 else odd

        def change(m, where=where, value=value):
            for key in where[:-1]:
                m = m[key]
            m[where[-1]] = value

        _edit(copy, change)
        try:
            with budget(5):
                load_map(copy, WORLD)
        except MapError as err:
            assert str(copy) in str(err) or str(copy.parent) in str(err), err
        except Exception as err:  # what the fuzz looks for
            escaped.append(f"{where} = {value!r:.40}: {type(err).__name__}: {err}"[:300])
        copy.write_text(json.dumps(meta))
    assert not escaped, "\n".join(escaped)
