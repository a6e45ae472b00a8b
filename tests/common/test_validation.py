"""Scalar argument checks."""

import numpy as np
import pytest

from common.validation import check_finite, check_int


@pytest.mark.parametrize("value", [3, np.int64(3), 3.0])
def test_check_int_takes_whole_numbers(value):
    out = check_int(value, "n")
    assert out == 3 and type(out) is int


@pytest.mark.parametrize("value", [0, -2, 2.5, "3", None, float("nan"), float("inf")])
def test_check_int_names_the_parameter(value):
    with pytest.raises(ValueError, match=r"episodes must be an integer >= 1, got "):
        check_int(value, "episodes")


def test_check_int_minimum():
    assert check_int(0, "videos", minimum=0) == 0
    with pytest.raises(ValueError, match="videos must be an integer >= 0, got -1"):
        check_int(-1, "videos", minimum=0)


@pytest.mark.parametrize("value", [float("nan"), float("inf"), True, "1", None])
def test_check_finite_refuses(value):
    with pytest.raises(ValueError, match="weight must be a finite number"):
        check_finite(value, "weight")


def test_check_finite_takes_reals():
    assert check_finite(np.float32(0.5), "w") == 0.5 and check_finite(-2, "w") == -2.0
