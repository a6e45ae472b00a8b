"""``experiments.servo.fix_offline``'s recordings are read as untrusted input and written
atomically."""

import numpy as np
import pytest

from experiments.servo.fix_offline import load_recording


def _write(path, **overrides):
    arrays = {
        "world": np.array("lawn"),
        "features": np.zeros((2, 5, 4), np.float32),
        "odometry": np.zeros((2, 5, 3)),
        "truth": np.zeros((2, 5, 3)),
        "start": np.zeros((2, 3)),
        "target": np.array([1, 2]),
    }
    arrays.update(overrides)
    np.savez(path, **{k: v for k, v in arrays.items() if v is not None})
    return path


def test_a_good_recording_loads(tmp_path):
    rec = load_recording(_write(tmp_path / "r.npz"))
    assert rec["world"] == "lawn" and rec["features"].shape == (2, 5, 4)


@pytest.mark.parametrize(
    "overrides, message",
    [
        ({"world": np.array("mars")}, "world must be one of"),
        ({"odometry": np.zeros((2, 5, 2))}, "expected features"),
        ({"start": np.full((2, 3), np.nan)}, "expected features"),
        ({"target": None}, "not a recording"),
        ({"world": np.array([object()], dtype=object)}, "not a recording"),
    ],
)
def test_a_bad_recording_is_refused(tmp_path, overrides, message):
    with pytest.raises(ValueError, match=message):
        load_recording(_write(tmp_path / "r.npz", **overrides))


def test_not_an_npz(tmp_path):
    path = tmp_path / "r.npz"
    path.write_bytes(b"not a zip")
    with pytest.raises(ValueError, match="not a recording"):
        load_recording(path)
