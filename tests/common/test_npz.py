"""The bounded ``.npz`` reader: arrays that declare more than MAX_ARRAY_BYTES in all are
refused from their headers, before anything is decompressed."""

import numpy as np
import pytest

from common import npz
from common.npz import UnreadableNpz, read_arrays
from sim.dataset import write_sequence


def test_arrays_beyond_the_cap_are_refused_from_their_headers(tmp_path, monkeypatch):
    path = tmp_path / "bomb.npz"
    write_sequence(path, {"a": np.zeros(3 << 20, np.uint8), "b": np.zeros(3, np.float32)})
    assert path.stat().st_size < 20_000  # 3 MiB of zeros pack a thousand times
    assert read_arrays(path)["a"].size == 3 << 20
    monkeypatch.setattr(npz, "MAX_ARRAY_BYTES", 1 << 20)
    with pytest.raises(UnreadableNpz, match=r"declare 3145740 bytes, more than MAX_ARRAY_BYTES"):
        read_arrays(path)


def test_the_cap_is_stated():
    assert npz.MAX_ARRAY_BYTES == 4 << 30
