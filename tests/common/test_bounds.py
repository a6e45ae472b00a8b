"""The physical bounds the readers share: each check names what is wrong, or says nothing."""

import re

import numpy as np
import pytest

from common import bounds


def test_values_within_the_bounds_pass():
    assert bounds.pose_problem([[1.0, -2.0, 30.0], [1e6, -1e6, -1e6]]) is None
    assert bounds.range_problem([0.0, 1.5, np.inf, 1e4]) is None
    assert bounds.angle_problem(np.linspace(-np.pi, np.pi, 5)) is None
    assert bounds.command_problem([[0.5, -1.0]]) is None
    assert bounds.time_problem([0.0, 1.0, 1.0, 2.0]) is None  # equal stamps are fine


@pytest.mark.parametrize(
    ("check", "values", "match"),
    [
        (bounds.pose_problem, [[0.0, 0.0, 0.0], [np.nan, 0.0, 0.0]], r"NaN or infinity \(at"),
        (bounds.pose_problem, [[0.0, 2e6, 0.0]], r"position 2000000.0 at element \(0, 1\)"),
        (bounds.pose_problem, [[0.0, 0.0, -1e7]], "heading -10000000.0 at row 0"),
        (bounds.range_problem, [1.0, np.nan], r"range holds NaN \(at row 1\)"),
        (bounds.range_problem, [1.0, -0.5], r"negative range -0.5 \(at row 1\)"),
        (bounds.range_problem, [1e300], "beyond the bound of 10000 m"),
        (bounds.angle_problem, [0.0, 7.0], "beam angle 7.0 at row 1"),
        (bounds.command_problem, [[np.inf, 0.0]], "command holds NaN or infinity"),
        (bounds.time_problem, [0.0, 2.0, 1.0], r"goes backwards at row 2 \(1.0 after 2.0\)"),
        (bounds.time_problem, [1e11], "beyond the bound of 1e.10 s"),
    ],
)
def test_values_beyond_the_bounds_are_named(check, values, match):
    problem = check(np.array(values))
    assert problem is not None
    assert re.search(match, problem), problem


def test_messages_name_the_default_subject_and_the_unit():
    assert bounds.time_problem([0.0, np.nan]).startswith("time holds NaN or infinity")
    assert bounds.command_problem([[2e3, 0.0]]) == (
        "command 2000.0 at element (0, 0) is beyond the bound of 1000 m/s or rad/s"
    )
    assert bounds.time_problem([2.0, 1.0], "stamp") == (
        "stamp goes backwards at row 1 (1.0 after 2.0); the frames must be in recording order"
    )


def test_unsigned_stamps_going_backwards_are_caught():
    # integer stamps (nanoseconds) as unsigned integers: their difference must not wrap around
    assert "goes backwards at row 1" in bounds.time_problem(np.array([5, 3], dtype=np.uint64))


def test_non_finite_values_are_placed_scalar_or_array():
    assert bounds.angle_problem(float("nan")) == "beam angle nan is not finite"
    assert bounds.angle_problem([0.5, np.inf]) == "beam angle holds NaN or infinity (at row 1)"
    assert bounds.pose_problem([[0.0, 0.0, 0.0], [np.nan, 0.0, 0.0]]) == (
        "pose position holds NaN or infinity (at element (1, 0))"
    )
    assert bounds.pose_problem([0.0, 0.0, 2e6]) == (
        "pose heading 2000000.0 is beyond the bound of 1e+06 rad"
    )


def test_a_negative_range_is_named_after_zeros_and_small_ranges():
    assert bounds.range_problem([0.0, 0.5, -2.0]) == "negative range -2.0 (at row 2)"


def test_integers_too_large_for_int64_are_numbers_beyond_the_bound():
    big = 2**70  # a JSON integer: no int64 holds it, a float does
    assert "beyond the bound of 1e+06 m" in bounds.pose_problem([[big, 0, 0]])
    assert "beyond the bound of 10000 m" in bounds.range_problem([1, big])
    assert "beyond the bound of 1e+10 s" in bounds.time_problem([0, big])
    assert "beyond the bound of 1000 m/s" in bounds.command_problem([[big, 0]])
