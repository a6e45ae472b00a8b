"""``--world`` on the command line: all, a canonical world or FAMILY:SEED."""

import argparse
import json

import pytest

from scripts.args import world_choice, worlds
from scripts.cli import main

BAD = ["maze:3", "hallway:x", "hallway:-1", "Hallway", "hallway:", "lawn:1000000", ""]


def test_world_choice_accepts_and_normalises():
    assert world_choice("all") == "all" and worlds("all") == ("hallway", "lawn")
    assert world_choice("hallway:17") == "hallway:17" and world_choice("lawn:0") == "lawn"
    for text in BAD:
        with pytest.raises(argparse.ArgumentTypeError, match="--world must be .*FAMILY:SEED"):
            world_choice(text)


@pytest.mark.parametrize("command", ["collect", "servo-eval", "sweep", "worlds"])
@pytest.mark.parametrize("text", ["maze:3", "hallway:x", "hallway:-1"])
def test_a_bad_world_is_a_usage_error_naming_the_forms(command, text, tmp_path, capsys):
    with pytest.raises(SystemExit) as caught:
        main([command, f"--world={text}", "--out", str(tmp_path)])
    assert caught.value.code == 2
    err = capsys.readouterr().err
    assert "FAMILY:SEED" in err and "Traceback" not in err


def test_worlds_writes_a_generated_world_without_a_colon(tmp_path, capsys):
    assert main(["worlds", "--world", "lawn:3", "--out", str(tmp_path)]) == 0
    assert (tmp_path / "lawn-3.xml").is_file()


def test_collect_a_generated_world(tmp_path):
    args = ["collect", "--world", "lawn:3", "--out", str(tmp_path), "--frames", "2"]
    assert main([*args, "--jobs", "1", "--width", "32", "--height", "24"]) == 0
    meta = json.loads((tmp_path / "meta.json").read_text())
    assert meta["settings"]["worlds"] == ["lawn:3"] and meta["complete"]
    assert all(":" not in e["file"] for e in meta["sequences"].values())
    assert meta["manifolds"][0] == "lawn:3"
