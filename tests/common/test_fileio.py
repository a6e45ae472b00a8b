"""Atomic writes, JSON coercion, and reading only regular files."""

import json
import os
from pathlib import Path

import numpy as np
import pytest

from common.fileio import (
    NotARegularFile,
    UnreadableJSON,
    atomic_path,
    atomic_write_bytes,
    jsonable,
    open_regular,
    read_json,
    write_json,
    write_png,
)


def test_jsonable_converts_numpy_and_paths_recursively():
    obj = {
        np.int64(3): np.float64(0.5),
        "a": (np.arange(3), [np.bool_(True), None]),
        "p": Path("x") / "y.png",
        (1, 2): "tuple key",
    }
    out = jsonable(obj)
    assert out == {3: 0.5, "a": [[0, 1, 2], [True, None]], "p": "x/y.png", "(1, 2)": "tuple key"}
    assert type(next(iter(out))) is int and type(out[3]) is float
    json.dumps(out)  # nothing numpy is left


def test_jsonable_finite_writes_non_finite_numbers_as_null(tmp_path):
    value = {1: np.array([1.5, np.inf]), "t": (np.int32(2), np.float64("nan"), float("-inf"))}
    assert jsonable(value, finite=True) == {1: [1.5, None], "t": [2, None, None]}
    assert jsonable(np.array([np.nan]))[0] != jsonable(np.array([np.nan]))[0]  # default: kept
    write_json(tmp_path / "x.json", value, finite=True)
    assert json.loads((tmp_path / "x.json").read_text()) == {"1": [1.5, None], "t": [2, None, None]}


def test_jsonable_refuses_what_json_cannot_hold():
    with pytest.raises(TypeError, match="set is not JSON serialisable"):
        jsonable({"x": {1, 2}})


def test_write_json_is_indented_and_ends_in_newline(tmp_path):
    write_json(tmp_path / "r.json", {"n": np.int32(2), "v": np.array([1.5])})
    text = (tmp_path / "r.json").read_text()
    assert text == json.dumps({"n": 2, "v": [1.5]}, indent=2) + "\n"


def test_failed_writes_leave_nothing_behind(tmp_path):
    target = tmp_path / "f.bin"
    atomic_write_bytes(target, b"old")
    with pytest.raises(RuntimeError), atomic_path(target) as tmp:
        tmp.write_bytes(b"half")
        raise RuntimeError("writer failed")
    assert target.read_bytes() == b"old"
    assert sorted(p.name for p in tmp_path.iterdir()) == ["f.bin"]
    with pytest.raises(TypeError):
        atomic_write_bytes(target, "not bytes")
    assert target.read_bytes() == b"old"
    assert sorted(p.name for p in tmp_path.iterdir()) == ["f.bin"]


def test_write_png_round_trips_rgb(tmp_path):
    cv2 = pytest.importorskip("cv2")
    rgb = np.zeros((4, 5, 3), np.uint8)
    rgb[..., 0] = 200  # red
    path = write_png(tmp_path / "sub" / "img.png", rgb)
    np.testing.assert_array_equal(cv2.imread(str(path))[..., ::-1], rgb)


def test_special_files_are_refused_before_they_are_read(tmp_path):
    pipe = tmp_path / "pipe.json"
    os.mkfifo(pipe)  # no writer: a blocking open would never return
    link = tmp_path / "zero.json"
    link.symlink_to("/dev/zero")
    for path, what in (
        (pipe, "a named pipe"),
        (link, "a link to a character device"),
        (tmp_path, "a folder"),
    ):
        with pytest.raises(NotARegularFile, match=f"is {what}, not a regular file"):
            open_regular(path)
        with pytest.raises(UnreadableJSON, match=what):
            read_json(path)
    with pytest.raises(FileNotFoundError):
        read_json(tmp_path / "missing.json")
    good = tmp_path / "good.json"
    good.write_text('{"a": 1}')
    (tmp_path / "link.json").symlink_to(good)
    assert read_json(tmp_path / "link.json") == {"a": 1}


def test_an_integer_of_too_many_digits_is_unreadable_json(tmp_path):
    path = tmp_path / "big.json"
    path.write_text("[" + "9" * 5000 + "]")
    with pytest.raises(UnreadableJSON):
        read_json(path)


def test_json_beyond_the_cap_is_refused_unread(tmp_path):
    path = tmp_path / "big.json"
    path.write_text("[" + "0, " * 100 + "0]")
    with pytest.raises(UnreadableJSON, match="more than the 100 bytes read as JSON"):
        read_json(path, max_bytes=100)
    assert len(read_json(path)) == 101
