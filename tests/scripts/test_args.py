"""The command line's argument types."""

import argparse

import pytest

from scripts.args import (
    frame_count,
    non_negative_float,
    non_negative_int,
    policies,
    policy_arg,
    policy_name,
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


def test_policy_name_is_ours_or_a_factory_path():
    assert policy_name("signal") == "signal"
    assert policy_name("examples.my_policy:make_policy") == "examples.my_policy:make_policy"
    for bad in ("nope", "examples.my_policy", "examples.my policy:f", ":f", "a.b:c.d", "a:b:c"):
        with pytest.raises(argparse.ArgumentTypeError, match="package.module:factory"):
            policy_name(bad)


def test_policy_arg_reads_json_values_else_text():
    assert policy_arg("speed=0.5") == ("speed", 0.5)
    assert policy_arg("steps=3") == ("steps", 3)
    assert policy_arg("fast=true") == ("fast", True)
    assert policy_arg("mode=greedy") == ("mode", "greedy")
    assert policy_arg("views=[1, 2]") == ("views", [1, 2])
    for bad in ("speed", "=1", "two words=1"):
        with pytest.raises(argparse.ArgumentTypeError, match="KEY=VALUE"):
            policy_arg(bad)
    with pytest.raises(argparse.ArgumentTypeError, match="finite"):
        policy_arg("speed=NaN")
