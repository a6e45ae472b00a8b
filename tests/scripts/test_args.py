"""The command line's argument types."""

import argparse

import pytest

from scripts.args import (
    frame_count,
    non_negative_float,
    non_negative_int,
    policies,
    positive_int,
    worlds,
)


def test_positive_int():
    assert positive_int("3") == 3
    with pytest.raises(argparse.ArgumentTypeError, match="integer >= 1, got 0"):
        positive_int("0")
    with pytest.raises(ValueError):
        positive_int("two")


@pytest.mark.parametrize("text", ["-1", "inf", "nan", "x"])
def test_non_negative_float_refuses(text):
    with pytest.raises(argparse.ArgumentTypeError, match="number >= 0"):
        non_negative_float(text)


def test_non_negative_float_and_worlds():
    assert non_negative_float("0") == 0.0 and non_negative_float("2.5") == 2.5
    assert worlds("lawn") == ("lawn",)
    assert set(worlds("all")) == {"hallway", "lawn"}


def test_policies_name_the_unknown_ones():
    assert policies("servo, random") == ("servo", "random")
    with pytest.raises(argparse.ArgumentTypeError, match=r"unknown policies \['teleport'\]"):
        policies("servo,teleport")


def test_non_negative_int_for_seeds():
    assert non_negative_int("0") == 0 and non_negative_int("7") == 7
    with pytest.raises(argparse.ArgumentTypeError, match="integer >= 0, got -1"):
        non_negative_int("-1")
    with pytest.raises(ValueError):
        non_negative_int("1.5")


def test_frame_count_is_at_least_two():
    assert frame_count("2") == 2
    with pytest.raises(argparse.ArgumentTypeError, match="integer >= 2, got 1"):
        frame_count("1")
