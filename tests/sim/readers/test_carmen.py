"""Carmen log reader: FLASER and ROBOTLASER1 lines, gzip or plain, refusing bad input."""

import gzip
from pathlib import Path

import numpy as np
import pytest

from sim.readers.carmen import CarmenError, read_carmen


def flaser(ranges, pose=(1.0, 2.0, 0.5), odom=(1.1, 2.1, 0.4), t=10.0) -> str:
    values = " ".join(str(r) for r in ranges)
    p = " ".join(str(v) for v in (*pose, *odom))
    return f"FLASER {len(ranges)} {values} {p} {t} host {t}"


def robotlaser(ranges, pose=(3.0, 4.0, 1.0), start=-1.5, res=0.5, max_range=8.0, t=5.0) -> str:
    values = " ".join(str(r) for r in ranges)
    head = f"0 {start} {res * (len(ranges) - 1)} {res} {max_range} 0.01 0"
    tail = f"{pose[0]} {pose[1]} {pose[2]} 0 0 0 0.1 0.0 1 1 0 {t} host {t}"
    return f"ROBOTLASER1 {head} {len(ranges)} {values} 2 7 8 {tail}"


def write(tmp_path, lines, name="log.txt", gz=False) -> Path:
    path = tmp_path / name
    text = "\n".join(lines) + "\n"
    if gz:
        with gzip.open(path, "wt") as f:
            f.write(text)
    else:
        path.write_text(text)
    return path


@pytest.mark.parametrize("gz", [False, True])
def test_reads_flaser_plain_and_gzip(tmp_path, gz):
    lines = [
        "# message formats defined: PARAM ODOM FLASER",
        "PARAM robot_front_laser_max 6.0 nohost 0",
        "ODOM 0 0 0 0 0 0 0.1 host 0.1",
        flaser([1.0, 2.0, 6.0]),
        flaser([1.5, 2.5, 3.5], pose=(2.0, 2.0, 0.0), t=11.0),
    ]
    log = read_carmen(write(tmp_path, lines, gz=gz), message="FLASER")
    assert len(log) == 2 and log.message == "FLASER"
    np.testing.assert_array_equal(log.ranges, [[1.0, 2.0, 6.0], [1.5, 2.5, 3.5]])
    np.testing.assert_allclose(log.angles, [-np.pi / 2, 0.0, np.pi / 2])
    np.testing.assert_array_equal(log.poses, [[1.0, 2.0, 0.5], [2.0, 2.0, 0.0]])
    np.testing.assert_array_equal(log.odometry[0], [1.1, 2.1, 0.4])
    np.testing.assert_array_equal(log.timestamps, [10.0, 11.0])
    np.testing.assert_array_equal(log.line_numbers, [4, 5])
    assert log.max_range == 6.0  # from PARAM robot_front_laser_max
    assert read_carmen(write(tmp_path, lines[2:]), max_range=9.0).max_range == 9.0
    # without the PARAM the largest reading is the no-return value
    assert read_carmen(write(tmp_path, lines[2:])).max_range == 6.0


def test_the_three_maximum_range_sources_are_told_apart(tmp_path):
    # The PARAM (8 m) is larger than every reading (at most 6 m, a log with no no-return):
    # the PARAM wins; without it, the largest reading; ROBOTLASER1's own field beats both
    scans = [flaser([1.0, 2.0, 6.0]), flaser([1.5, 2.5, 3.5], t=11.0)]
    param = "PARAM robot_front_laser_max 8.0 nohost 0"
    assert read_carmen(write(tmp_path, [param, *scans]), message="FLASER").max_range == 8.0
    # a PARAM after the scans counts too; another PARAM's value does not
    other = "PARAM robot_rear_laser_max 30.0 nohost 0"
    assert read_carmen(write(tmp_path, [other, *scans, param])).max_range == 8.0
    assert read_carmen(write(tmp_path, [other, *scans])).max_range == 6.0
    # a PARAM smaller than a reading still names the sensor's range (the reading is then a
    # no-return, whatever it says)
    small = "PARAM robot_front_laser_max 5.0 nohost 0"
    assert read_carmen(write(tmp_path, [small, *scans])).max_range == 5.0
    # the override beats the PARAM
    assert read_carmen(write(tmp_path, [param, *scans]), max_range=7.5).max_range == 7.5
    # ROBOTLASER1 states its own (9 m), beating the PARAM and the largest reading (3 m)
    lines = [param, robotlaser([1.0, 2.0, 3.0], max_range=9.0)]
    assert read_carmen(write(tmp_path, lines)).max_range == 9.0


def test_reads_robotlaser_with_its_own_geometry(tmp_path):
    lines = [flaser([1.0, 1.0, 1.0, 1.0]), robotlaser([1.0, 2.0, 3.0, 8.0])]
    log = read_carmen(write(tmp_path, lines))  # auto prefers ROBOTLASER1
    assert log.message == "ROBOTLASER1" and log.odometry is None
    np.testing.assert_allclose(log.angles, [-1.5, -1.0, -0.5, 0.0])
    assert log.max_range == 8.0 and log.timestamps[0] == 5.0
    np.testing.assert_array_equal(log.poses, [[3.0, 4.0, 1.0]])
    assert len(read_carmen(write(tmp_path, lines), message="FLASER")) == 1


@pytest.mark.parametrize(
    ("bad", "match"),
    [
        (flaser([1.0, 2.0, 3.0]).rsplit(" ", 5)[0], "line 2: FLASER with 3 ranges needs 14"),
        (flaser([1.0, "abc", 3.0]), "line 2: non-numeric range field 'abc'"),
        (flaser([1.0, "nan", 3.0]), "line 2: range contains NaN"),
        (flaser([1.0, 2.0, 3.0], pose=(0.0, "nan", 0.0)), "line 2: pose contains NaN"),
        (flaser([1.0, 2.0, 3.0]).replace("FLASER 3", "FLASER 4"), "count that does not match"),
        (flaser([1.0, 2.0, 3.0]).replace("FLASER 3", "FLASER x"), "count must be an integer"),
        (flaser([1.0, 2.0]), "line 2: 2 ranges, but line 1 has 3"),
        (flaser([1.0, -2.0, 3.0]), "line 2: negative range"),
        ("FLASER", "line 2: truncated line"),
    ],
)
def test_bad_lines_name_file_and_line(tmp_path, bad, match):
    path = write(tmp_path, [flaser([1.0, 2.0, 3.0]), bad, flaser([1.0, 2.0, 3.0])])
    with pytest.raises(CarmenError, match=match) as info:
        read_carmen(path)
    assert str(path) in str(info.value)


def test_bad_robotlaser_and_files(tmp_path):
    ok = robotlaser([1.0, 2.0])
    with pytest.raises(CarmenError, match="line 2: ROBOTLASER1 with 2 ranges and 2 remissions"):
        read_carmen(write(tmp_path, [ok, ok.rsplit(" ", 3)[0]]))
    with pytest.raises(CarmenError, match="line 2: beam geometry"):
        read_carmen(write(tmp_path, [ok, robotlaser([1.0, 2.0], res=0.25)]))
    with pytest.raises(CarmenError, match="no FLASER lines, so no scans"):
        read_carmen(write(tmp_path, ["# nothing", "ODOM 0 0 0 0 0 0 0 host 0"]))
    with pytest.raises(CarmenError, match="no FLASER lines"):
        read_carmen(write(tmp_path, []))
    broken = tmp_path / "broken.gz"
    broken.write_bytes(gzip.compress(b"FLASER 1 1.0 0 0 0 0 0 0 1 h 1\n" * 50)[:40])
    with pytest.raises(CarmenError, match="broken.gz: cannot read"):
        read_carmen(broken)
    with pytest.raises(CarmenError, match="cannot read"):
        read_carmen(tmp_path / "missing.log")
    with pytest.raises(ValueError, match="message must be"):
        read_carmen(write(tmp_path, [ok]), message="RLASER")


def test_the_radish_logs(aces_log, csail_log):
    aces = read_carmen(aces_log)
    assert aces.ranges.shape == (440, 180) and aces.max_range == 50.0
    csail = read_carmen(csail_log)
    assert csail.ranges.shape == (406, 361) and csail.max_range == 50.0  # PARAM in the log
    np.testing.assert_allclose(np.diff(csail.angles), np.deg2rad(0.5))
    # the corrected logs repeat the corrected pose in the odometry fields
    np.testing.assert_array_equal(aces.poses, aces.odometry)


def test_the_shipped_slice_of_a_real_log(aces_slice_log):
    # every third scan of the ACES log: no robot_front_laser_max PARAM, so the largest reading
    # (Carmen's no-return value) is the maximum range
    log = read_carmen(aces_slice_log)
    assert log.message == "FLASER" and log.ranges.shape == (147, 180)
    assert log.max_range == 50.0 and log.ranges.max() == 50.0
    assert 0.0 < np.median(log.ranges) < 50.0
    np.testing.assert_allclose(log.angles[[0, -1]], [-np.pi / 2, np.pi / 2])
    np.testing.assert_array_equal(log.poses, log.odometry)  # corrected: pose repeated
    assert np.all(np.diff(log.timestamps) > 0)
    # the route: about 300 m, in steps of at most a few metres between the kept scans
    steps = np.hypot(*np.diff(log.poses[:, :2], axis=0).T)
    assert steps.max() < 4.0 and 250.0 < steps.sum() < 400.0
    np.testing.assert_array_equal(log.line_numbers[:2], [7, 8])  # 6 header lines


def test_the_shipped_slice_is_the_full_log_thinned(aces_slice_log, aces_log):
    with gzip.open(aces_log, "rt") as f:
        full = f.read().splitlines()
    with gzip.open(aces_slice_log, "rt") as f:
        thin = f.read().splitlines()
    scans = [line for line in full if line.startswith("FLASER")]
    header = [line for line in full if line.startswith(("#", "PARAM"))]
    assert thin == header + scans[::3]
    np.testing.assert_array_equal(
        read_carmen(aces_slice_log).ranges, read_carmen(aces_log).ranges[::3]
    )


def test_scans_without_beams_or_angle_step_are_refused(tmp_path):
    # FLASER 0 failed in numpy ("zero-size array"), ROBOTLASER1 0 gave ranges of shape (1, 0)
    with pytest.raises(CarmenError, match="line 1: FLASER with 0 ranges; need at least 1"):
        read_carmen(write(tmp_path, [flaser([])]))
    with pytest.raises(CarmenError, match="line 1: ROBOTLASER1 with 0 ranges; need at least 1"):
        read_carmen(write(tmp_path, [robotlaser([])]))
    with pytest.raises(CarmenError, match="line 2: ROBOTLASER1 angular_resolution is 0"):
        read_carmen(write(tmp_path, [robotlaser([1.0, 2.0]), robotlaser([1.0, 2.0], res=0.0)]))


@pytest.mark.parametrize("max_range", ["5", True, 0.0, -1.0, float("nan"), float("inf")])
def test_bad_max_range_is_refused(tmp_path, max_range):
    path = write(tmp_path, [flaser([1.0, 2.0, 3.0])])
    with pytest.raises(ValueError, match="max_range must be"):
        read_carmen(path, max_range=max_range)
