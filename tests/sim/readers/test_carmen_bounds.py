"""Carmen logs with values no robot records, damaged files and odd line breaks: each refused
with a CarmenError naming the file, the line and the bound; the unusual accepted with a warning."""

import gzip

import numpy as np
import pytest

from sim.readers.carmen import CarmenError, read_carmen
from tests.sim.readers.test_carmen import flaser, robotlaser, write


@pytest.mark.parametrize(
    ("bad", "match"),
    [
        (flaser([1.0, 2.0, 3.0], pose=(1e308, 0.0, 0.0)), r"laser pose position 1e\+308"),
        (flaser([1.0, 2.0, 3.0], pose=(0.0, -2e6, 0.0)), "beyond the bound of 1e.06 m"),
        (flaser([1.0, 2.0, 3.0], pose=(0.0, 0.0, 1e9)), "laser pose heading"),
        (flaser([1.0, 2.0, 3.0], odom=(0.0, 1e7, 0.0)), "odometry pose position"),
        (flaser([1.0, 1e300, 3.0]), r"range 1e\+300 \(at row 1\) is beyond the bound of 10000"),
        (flaser([1.0, 2.0, 3.0], t=1e12), "timestamp 1000000000000.0 is beyond"),
        (flaser([1.0, 2.0, 3.0], t="inf"), "pose contains NaN or infinity"),
    ],
)
def test_values_beyond_the_bounds_are_refused(tmp_path, bad, match):
    path = write(tmp_path, [flaser([1.0, 2.0, 3.0]), bad])
    with pytest.raises(CarmenError, match=match) as info:
        read_carmen(path)
    assert f"{path}, line 2:" in str(info.value)


@pytest.mark.parametrize(
    ("kwargs", "match"),
    [
        ({"res": 10.0}, r"angular_resolution 10.0 rad is outside \(0, 2 pi\]"),
        ({"res": -0.5}, "angular_resolution -0.5 rad is outside"),
        ({"start": 7.0}, "start_angle 7.0 is beyond the bound of 6.28319 rad"),
        ({"max_range": 1e300}, r"maximum_range 1e\+300 m is outside \(0, 10000\]"),
        ({"max_range": 0.0}, "maximum_range 0.0 m is outside"),
    ],
)
def test_robotlaser_geometry_beyond_the_bounds_is_refused(tmp_path, kwargs, match):
    path = write(tmp_path, [robotlaser([1.0, 2.0], **kwargs)])
    with pytest.raises(CarmenError, match=f"line 1: ROBOTLASER1 {match}"):
        read_carmen(path)


def test_a_field_of_view_of_zero_is_refused_for_more_than_one_beam(tmp_path):
    zero_fov = robotlaser([1.0, 2.0]).replace(" -1.5 0.5 0.5 ", " -1.5 0.0 0.5 ")
    with pytest.raises(CarmenError, match=r"line 1: ROBOTLASER1 field_of_view 0.0 rad"):
        read_carmen(write(tmp_path, [zero_fov]))
    assert len(read_carmen(write(tmp_path, [robotlaser([1.0])]))) == 1  # one beam: fov 0


def test_param_max_range_beyond_the_bound_is_refused(tmp_path):
    lines = ["PARAM robot_front_laser_max 1e300 host 0", flaser([1.0, 2.0, 3.0])]
    with pytest.raises(CarmenError, match="line 1: robot_front_laser_max"):
        read_carmen(write(tmp_path, lines))
    with pytest.raises(ValueError, match="at most 10000"):
        read_carmen(write(tmp_path, [flaser([1.0, 2.0, 3.0])]), max_range=1e5)


def test_readings_above_the_stated_maximum_are_kept_as_no_returns(tmp_path):
    lines = ["PARAM robot_front_laser_max 50 host 0", flaser([1.0, 81.91, 3.0])]
    log = read_carmen(write(tmp_path, lines))
    assert log.max_range == 50.0 and log.ranges[0, 1] == np.float64(81.91)


@pytest.mark.parametrize("char", ["\f", "\v", "\x1c", "\x1e"])
def test_line_numbers_count_only_newlines(tmp_path, char):
    # str.splitlines splits at form feeds, vertical tabs and \x1c-\x1e too
    lines = [f"# a comment{char}with a control character", flaser([1.0, 2.0, 3.0]), "FLASER"]
    with pytest.raises(CarmenError, match="line 3: truncated line"):
        read_carmen(write(tmp_path, lines))
    assert read_carmen(write(tmp_path, lines[:2])).line_numbers.tolist() == [2]


def test_timestamps_going_backwards_warn_and_keep_file_order(tmp_path):
    lines = [flaser([1.0, 2.0, 3.0], t=5.0), flaser([1.0, 2.0, 3.0], t=4.0)]
    with pytest.warns(UserWarning, match="line 2: the timestamp goes backwards"):
        log = read_carmen(write(tmp_path, lines))
    assert log.timestamps.tolist() == [5.0, 4.0]


def test_every_damaged_gzip_is_a_carmen_error(tmp_path):
    data = gzip.compress(("\n".join([flaser([1.0, 2.0, 3.0])] * 40) + "\n").encode(), mtime=0)
    rng = np.random.default_rng(7)
    kinds = set()
    for case in range(60):
        damaged = bytearray(data)
        at = int(rng.integers(10, len(damaged)))
        damaged[at] ^= 1 << int(rng.integers(8))
        path = tmp_path / f"flip{case}.log.gz"
        path.write_bytes(bytes(damaged))
        try:
            read_carmen(path)
        except CarmenError as err:
            kinds.add(type(err.__cause__).__name__ if err.__cause__ else "CarmenError")
            assert str(path) in str(err)
    assert "error" in kinds  # zlib.error: escaped as itself before


def test_robotlaser_geometry_at_its_bounds_is_read(tmp_path):
    # one beam: resolution and field of view 0 are fine, and a negative one names [0, 2 pi]
    log = read_carmen(write(tmp_path, [robotlaser([1.0], res=0.0)]))
    np.testing.assert_array_equal(log.angles, [-1.5])
    with pytest.raises(CarmenError, match=r"angular_resolution -0.5 rad is outside \[0, 2 pi\]$"):
        read_carmen(write(tmp_path, [robotlaser([1.0], res=-0.5)]))
    # a resolution and field of view of a full turn, maximum ranges just above 0 and at 10^4 m
    assert len(read_carmen(write(tmp_path, [robotlaser([1.0, 2.0], res=2 * np.pi)]))) == 1
    for max_range in (0.5, 1e4):
        assert read_carmen(write(tmp_path, [robotlaser([0.1], max_range=max_range)])).max_range == (
            max_range
        )


def test_zero_resolution_message_says_why(tmp_path):
    with pytest.raises(CarmenError) as info:
        read_carmen(write(tmp_path, [robotlaser([1.0, 2.0], res=0.0)]))
    assert str(info.value).endswith(
        "line 1: ROBOTLASER1 angular_resolution is 0, so all 2 beams would point the same way; "
        "need a non-zero angle between beams"
    )


_RL = robotlaser([1.0, 2.0])


@pytest.mark.parametrize(
    ("bad", "match"),
    [
        (_RL.replace("ROBOTLASER1 0 -1.5", "ROBOTLASER1 0 x"), "non-numeric header field 'x'$"),
        (_RL.replace(" 2 1.0 2.0 ", " 2 1.0 y "), "non-numeric range field 'y'$"),
        (_RL.replace("2 7 8 3.0 4.0", "2 7 8 3.0 z"), "non-numeric pose field 'z'$"),
        (
            _RL.replace("2 7 8 ", "q 7 8 "),
            "remission count must be an integer of at most 10 digits, got 'q'$",
        ),
        (_RL.rsplit(" 2 7 8 ", 1)[0], "truncated line, no remission count$"),
        (_RL.replace("2 7 8 ", "3 7 8 "), "a count that does not match its values\\)$"),
        (robotlaser([1.0, -2.0]), "negative range -2.0 \\(at row 1\\)$"),
        (robotlaser([]), "ROBOTLASER1 with 0 ranges; need at least 1$"),
        (robotlaser([1.0, 2.0], max_range=-1.0), "maximum_range -1.0 m is outside"),
    ],
)
def test_bad_robotlaser_lines_name_file_and_line(tmp_path, bad, match):
    path = write(tmp_path, [_RL, bad])
    with pytest.raises(CarmenError, match=match) as info:
        read_carmen(path)
    assert str(info.value).startswith(f"{path}, line 2: ")


def test_the_backwards_warning_names_the_first_line_and_counts(tmp_path):
    times = (1.0, 3.0, 2.0, 2.0, 2.5, 0.0)  # back at lines 3 and 6; equal and small steps are fine
    path = write(tmp_path, [flaser([1.0, 2.0, 3.0], t=t) for t in times])
    with pytest.warns(UserWarning) as record:
        read_carmen(path)
    (warning,) = record
    assert str(warning.message) == (
        f"{path}, line 3: the timestamp goes backwards (2 times in the log); the scans are kept "
        "in the order of the file"
    )


def test_equal_or_small_time_steps_do_not_warn(tmp_path, recwarn):
    path = write(tmp_path, [flaser([1.0, 2.0, 3.0], t=t) for t in (1.0, 1.0, 1.5, 1e10)])
    assert read_carmen(path).timestamps[-1] == 1e10  # the bound itself is a time
    assert not recwarn.list


def test_lines_are_the_files_lines(tmp_path):
    scan = flaser([1.0, 2.0, 3.0])
    path = tmp_path / "log.txt"
    path.write_text(f"{scan}\n\n{scan}")  # a blank line, and no newline at the end
    assert read_carmen(path).line_numbers.tolist() == [1, 3]
    path.write_text("# a comment\n\n")
    with pytest.raises(CarmenError, match=r"no FLASER lines, so no scans \(lines read: 2\)$"):
        read_carmen(path)


@pytest.mark.parametrize("gz", [False, True])
def test_text_that_is_not_ascii_is_refused(tmp_path, gz):
    path = write(tmp_path, ["# caf\u00e9", flaser([1.0, 2.0, 3.0])], gz=gz)
    with pytest.raises(CarmenError, match="cannot read as a .gzip. text Carmen log"):
        read_carmen(path)


def test_maximum_ranges_at_their_bounds(tmp_path):
    scans = [flaser([1.0, 2.0, 3.0])]
    for value in (0.5, 1e4):
        assert read_carmen(write(tmp_path, scans), max_range=value).max_range == value
        param = [f"PARAM robot_front_laser_max {value}", *scans]  # no host and time: still read
        assert read_carmen(write(tmp_path, param)).max_range == value
    with pytest.raises(CarmenError, match="line 1: robot_front_laser_max 0.0 m is outside"):
        read_carmen(write(tmp_path, ["PARAM robot_front_laser_max 0", *scans]))


def test_count_errors_name_the_count(tmp_path):
    bad = flaser([1.0, 2.0, 3.0]).replace("FLASER 3", "FLASER x")
    with pytest.raises(
        CarmenError, match=r"line 1: range count must be an integer of at most 10 digits, got 'x'$"
    ):
        read_carmen(write(tmp_path, [bad]))


def test_a_log_of_zero_readings_has_no_maximum_range(tmp_path):
    path = write(tmp_path, [flaser([0.0, 0.0, 0.0])] * 2)
    with pytest.raises(CarmenError) as info:
        read_carmen(path)
    assert str(info.value) == f"{path}: maximum range 0.0 is not a distance in (0, 10000] m"
    assert read_carmen(path, max_range=5.0).path == path


def test_changed_geometry_names_the_first_line(tmp_path):
    ok = robotlaser([1.0, 2.0])
    path = write(tmp_path, [ok, ok, robotlaser([1.0, 2.0], res=0.25)])
    with pytest.raises(CarmenError, match=r"line 3: beam geometry .* differs from line 1$"):
        read_carmen(path)
