"""Fuzzing the Carmen reader: damaged copies of small logs (truncations, byte flips in plain and
gzip files, field edits, special numbers) must give a CarmenError or a valid log, never another
exception, a hang or non-finite values. Seeded; about 1,000 cases in a few seconds."""

import warnings

import numpy as np
import pytest

from common.bounds import MAX_COORDINATE, MAX_RANGE
from sim.readers.carmen import CarmenError, read_carmen
from tests.sim.readers.fuzzing import budget, damaged_variants
from tests.sim.readers.test_carmen import flaser, robotlaser

CASE_BUDGET_S = 2.0


def _flaser_log(rng) -> str:
    lines = ["# a log", "PARAM robot_front_laser_max 50.0 host 0"]
    for k in range(6):
        pose = tuple(np.round(rng.uniform(-5, 5, 3), 3))
        lines.append(flaser(np.round(rng.uniform(0.1, 50, 5), 2), pose=pose, t=float(k)))
        lines.append(f"ODOM {k} 0 0 0 0 0 {k} host {k}")
    return "\n".join(lines) + "\n"


def _robotlaser_log(rng) -> str:
    lines = [robotlaser(np.round(rng.uniform(0.1, 8, 4), 2), t=float(k)) for k in range(6)]
    return "\n".join(lines) + "\n"


def _assert_valid(log):
    n, b = log.ranges.shape
    assert n >= 1 and b >= 1 and log.angles.shape == (b,)
    assert log.poses.shape == (n, 3) and log.timestamps.shape == (n,)
    assert len(log.line_numbers) == n and (np.diff(log.line_numbers) > 0).all()
    for values in (log.ranges, log.angles, log.poses, log.timestamps):
        assert np.isfinite(values).all()
    assert (log.ranges >= 0).all() and log.ranges.max() <= MAX_RANGE
    assert np.abs(log.poses[:, :2]).max() <= MAX_COORDINATE
    assert 0 < log.max_range <= MAX_RANGE
    if log.odometry is not None:
        assert np.isfinite(log.odometry).all()
    if log.message == "ROBOTLASER1" and b > 1:
        assert 0 < np.diff(log.angles).min() and np.ptp(log.angles) <= 2 * np.pi


@pytest.mark.parametrize(("make", "seed"), [(_flaser_log, 1), (_robotlaser_log, 2)])
def test_damaged_logs_give_a_carmen_error_or_a_valid_log(tmp_path, make, seed):
    rng = np.random.default_rng(seed)
    text = make(rng)
    _assert_valid(read_carmen(_write(tmp_path / "clean.log", text.encode())))
    outcomes = {}
    for case, (kind, data) in enumerate(damaged_variants(text, rng, per_kind=80)):
        path = _write(tmp_path / f"case{case}.log", data)
        with budget(CASE_BUDGET_S), warnings.catch_warnings():
            warnings.simplefilter("ignore", UserWarning)  # the unusual is read with a warning
            try:
                log = read_carmen(path)
            except CarmenError as err:
                assert str(path) in str(err), (kind, err)
                outcomes[kind, "refused"] = outcomes.get((kind, "refused"), 0) + 1
                continue
        _assert_valid(log)
        outcomes[kind, "read"] = outcomes.get((kind, "read"), 0) + 1
    # both outcomes occur for every kind of damage but the gzip truncations, which break the
    # stream (or leave no whole line) nearly always
    assert outcomes.get(("flipped gz", "refused"), 0) > 0
    assert outcomes.get(("edited", "refused"), 0) > 0 and outcomes.get(("edited", "read"), 0) > 0


def _write(path, data: bytes):
    path.write_bytes(data)
    return path
