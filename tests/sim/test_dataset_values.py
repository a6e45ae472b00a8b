"""The dataset reader refuses values no recording holds, naming the file and the array."""

import io
import json
import struct
import zipfile

import numpy as np
import pytest

from sim.dataset import DatasetError, load_dataset
from tests.sim.dataset_fixtures import sequence_arrays, write_dataset


def test_the_fixture_is_a_valid_dataset(tmp_path):
    ds = load_dataset(write_dataset(tmp_path))
    assert len(ds.sequences["lawn-left"]) == 5


def _changed(key, edit):
    arrays = sequence_arrays()
    arrays[key] = edit(arrays[key].copy())
    return arrays


def _at(index, value):
    def edit(a):
        a[index] = value
        return a

    return edit


@pytest.mark.parametrize(
    ("key", "edit", "match"),
    [
        ("odometry", _at((2, 0), np.nan), r"odometry position holds NaN or infinity \(at element"),
        ("odometry", _at((1, 2), np.inf), "odometry heading holds NaN or infinity"),
        ("poses", _at((0, 1), 1e300), "poses position 1e.300"),
        ("times", _at(3, np.nan), "times holds NaN"),
        ("times", _at(3, 0.05), r"times goes backwards at row 3 \(0.05 after 0.2"),
        ("angles", _at(1, np.inf), "angles holds NaN or infinity"),
        ("scans", _at((0, 0), np.nan), r"scans holds NaN \(at element \(0, 0\)\)"),
        ("scans", _at((4, 3), -1.0), "negative scans -1.0"),
        ("commands", _at((0, 0), np.nan), "commands holds NaN"),
        ("labels", _at(0, 99), "labels from 0 to 99, but meta.json has 2 manifolds"),
        ("labels", _at(0, -5), "labels from -5 to 1"),
        ("images", lambda a: a[:, :0, :0], r"images of shape \(0, 0, 3\)"),
    ],
)
def test_broken_values_are_refused_naming_the_array(tmp_path, key, edit, match):
    path = write_dataset(tmp_path, _changed(key, edit))
    with pytest.raises(DatasetError, match=match) as info:
        load_dataset(path)
    assert "lawn-left.npz" in str(info.value)


def test_scans_without_beams_are_refused(tmp_path):
    arrays = sequence_arrays()
    arrays["scans"], arrays["angles"] = arrays["scans"][:, :0], arrays["angles"][:0]
    with pytest.raises(DatasetError, match="scans of 0 beams"):
        load_dataset(write_dataset(tmp_path, arrays))


def test_no_return_beams_and_unwrapped_headings_are_fine(tmp_path):
    arrays = sequence_arrays()
    arrays["scans"][:] = np.inf
    arrays["odometry"][:, 2] = np.linspace(0, 40, 5)  # unwrapped: several turns
    assert load_dataset(write_dataset(tmp_path, arrays)).sequences["lawn-left"].scans.max() > 0


@pytest.mark.parametrize("version", [True, 1.5, "2", None])
def test_a_schema_version_must_be_an_integer_this_code_reads(tmp_path, version):
    with pytest.raises(DatasetError, match=f"schema version {version!r}"):
        load_dataset(write_dataset(tmp_path, schema_version=version))


def test_an_over_long_file_name_is_refused_before_the_file_system_is_asked(tmp_path):
    path = write_dataset(tmp_path)
    meta = json.loads((path / "meta.json").read_text())
    meta["sequences"]["lawn-left"]["file"] = "a" * 300 + ".npz"
    (path / "meta.json").write_text(json.dumps(meta))
    with pytest.raises(DatasetError, match="expected a plain file name"):
        load_dataset(path)


def _header(shape) -> bytes:
    buffer = io.BytesIO()
    header = {"descr": "<f8", "fortran_order": False, "shape": shape}
    np.lib.format.write_array_header_1_0(buffer, header)
    return buffer.getvalue()  # a header declaring a huge array, and no data


def _rewrite_npz(path, members):
    with zipfile.ZipFile(path, "w") as zf:
        for name, data in members.items():
            zf.writestr(name, data)


@pytest.mark.parametrize(
    ("members", "match"),
    [
        ({"images.npy": _header((10**13,))}, r"declares shape \(10000000000000,\)"),
        ({"images.npy": b"\x93NUMPY\x01\x00\x10\x00{'descr': (((\n"}, "cannot be read"),
        ({"../images.npy": b""}, "is not an array file"),
        ({"notes.txt": b"hello"}, "is not an array file"),
        ({"images.npy": b"\x93NUMPY\x07\x00"}, "format version"),
    ],
)
def test_odd_zip_members_are_a_dataset_error(tmp_path, members, match):
    path = write_dataset(tmp_path)
    _rewrite_npz(path / "lawn-left.npz", members)
    with pytest.raises(DatasetError, match=match):
        load_dataset(path, verify=False)


def test_a_damaged_deflate_stream_is_a_dataset_error(tmp_path):
    path = write_dataset(tmp_path)
    npz = path / "lawn-left.npz"
    data = bytearray(npz.read_bytes())
    with zipfile.ZipFile(npz) as zf:
        info = zf.getinfo("scans.npy")
    name_length, extra_length = struct.unpack("<HH", data[info.header_offset + 26 :][:4])
    start = info.header_offset + 30 + name_length + extra_length
    for k in range(start + 2, start + 12):  # inside the deflate stream
        data[k] ^= 0xFF
    npz.write_bytes(bytes(data))
    with pytest.raises(DatasetError, match="lawn-left.npz cannot be read"):
        load_dataset(path, verify=False)
