"""Carmen logs that are no plain small file: special files and links refused before they are
read, a cap on the text read (a gzip bomb stops there), line numbers that a lone carriage
return does not shift, counts of thousands of digits."""

import gzip
import os

import pytest

from sim.readers import carmen
from sim.readers.carmen import CarmenError, read_carmen
from tests.sim.readers.fuzzing import budget
from tests.sim.readers.test_carmen import flaser, write

SCAN = flaser([1.0, 2.0, 3.0])


def test_a_named_pipe_is_refused_without_blocking(tmp_path):
    path = tmp_path / "log.txt"
    os.mkfifo(path)  # no writer: opening it for reading blocks forever
    with budget(5), pytest.raises(CarmenError, match="is a named pipe, not a regular file"):
        read_carmen(path)


@pytest.mark.parametrize(
    ("target", "what"), [("/dev/zero", "a link to a character device"), ("/", "a link to a folder")]
)
def test_a_link_to_a_device_or_folder_is_refused(tmp_path, target, what):
    path = tmp_path / "log.txt"
    path.symlink_to(target)
    with budget(5), pytest.raises(CarmenError, match=what) as err:
        read_carmen(path)
    assert str(path) in str(err.value)


def test_a_folder_and_a_device_are_refused(tmp_path):
    with pytest.raises(CarmenError, match="is a folder"):
        read_carmen(tmp_path)
    with budget(5), pytest.raises(CarmenError, match="is a character device"):
        read_carmen("/dev/zero")


def test_a_link_to_a_log_is_read(tmp_path):
    path = tmp_path / "link.log"
    path.symlink_to(write(tmp_path, [SCAN]))
    assert len(read_carmen(path)) == 1


@pytest.mark.parametrize("gz", [False, True])
def test_text_beyond_the_cap_is_refused(tmp_path, monkeypatch, gz):
    monkeypatch.setattr(carmen, "MAX_LOG_BYTES", 4096)
    comments = ["# " + "x" * 97] * 41 + [SCAN]  # 4,100 bytes of comments, then a scan
    with pytest.raises(CarmenError, match="more than MAX_LOG_BYTES = 4096 bytes") as err:
        read_carmen(write(tmp_path, comments, gz=gz))
    assert "log.txt" in str(err.value)
    assert len(read_carmen(write(tmp_path, comments[-30:], gz=gz))) == 1


def test_a_gzip_bomb_stops_at_the_cap_quickly(tmp_path, monkeypatch):
    monkeypatch.setattr(carmen, "MAX_LOG_BYTES", 1 << 20)
    path = tmp_path / "bomb.log.gz"
    with gzip.open(path, "wb", compresslevel=9) as f:
        for _ in range(64):  # 64 MiB of one comment, ~64 KB on disk
            f.write(b"#" + b" " * ((1 << 20) - 2) + b"\n")
    assert path.stat().st_size < 200_000
    with budget(5), pytest.raises(CarmenError, match="more than MAX_LOG_BYTES"):
        read_carmen(path)


def test_the_cap_is_stated():
    assert carmen.MAX_LOG_BYTES == 1 << 30
    assert "MAX_LOG_BYTES" in carmen.__doc__


@pytest.mark.parametrize("gz", [False, True])
def test_a_lone_carriage_return_does_not_shift_line_numbers(tmp_path, gz):
    path = tmp_path / "log.txt"
    text = f"# a comment\rwith a carriage return\n{SCAN}\nFLASER\n"
    path.write_bytes(gzip.compress(text.encode()) if gz else text.encode())
    with pytest.raises(CarmenError, match="line 3: truncated line"):
        read_carmen(path)
    text = f"# a comment\rwith a carriage return\r\n{SCAN}\r\n{SCAN}\n"
    path.write_bytes(gzip.compress(text.encode()) if gz else text.encode())
    assert read_carmen(path).line_numbers.tolist() == [2, 3]


@pytest.mark.parametrize("count", ["9" * 5000, "9" * 11])
def test_a_count_of_many_digits_is_refused(tmp_path, count):
    # int() of 5000 digits raises a ValueError of its own
    with pytest.raises(CarmenError, match=r"line 2: range count must be an integer of at most"):
        read_carmen(write(tmp_path, [SCAN, f"FLASER {count} 1.0"]))
    robot = f"ROBOTLASER1 0 -1.5 1.0 0.5 8.0 0.01 0 2 1.0 2.0 {count} 7"
    with pytest.raises(CarmenError, match=r"line 1: remission count must be an integer of"):
        read_carmen(write(tmp_path, [robot]))
