"""Scalar argument checks."""

import numpy as np
import pytest

from common.validation import check_bool, check_finite, check_int, check_keys


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


@pytest.mark.parametrize("value", [True, False, np.bool_(True)])
def test_check_bool_takes_booleans(value):
    out = check_bool(value, "randomize")
    assert out is bool(value)


@pytest.mark.parametrize("value", [1, 0, "yes", None, 1.0])
def test_check_bool_names_the_parameter(value):
    with pytest.raises(ValueError, match="randomize must be True or False, got "):
        check_bool(value, "randomize")


def test_check_keys_takes_a_mapping_of_known_keys():
    assert check_keys(None, ("pose", "manifold"), "options") == {}
    assert check_keys({"pose": 1}, ("pose", "manifold"), "options") == {"pose": 1}


def test_check_keys_names_an_unknown_key_and_the_closest():
    with pytest.raises(ValueError, match=r"options has an unknown key 'poze'.*did you mean 'pose'"):
        check_keys({"poze": 1}, ("pose", "manifold"), "options")
    with pytest.raises(ValueError, match=r"unknown key 'zzz' \(known: \('pose', 'manifold'\)\)$"):
        check_keys({"zzz": 1}, ("pose", "manifold"), "options")


@pytest.mark.parametrize("value", [[("pose", 1)], "pose", 3])
def test_check_keys_refuses_what_is_no_mapping(value):
    with pytest.raises(TypeError, match="options must be a dict with keys from"):
        check_keys(value, ("pose",), "options")
