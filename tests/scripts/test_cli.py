"""The ``topomap`` command line: its help is quick to show and lists every subcommand on one
line, every subcommand's options stay."""

from __future__ import annotations

import argparse
import subprocess
import sys
from pathlib import Path

import pytest

from scripts.cli import build_parser, command_listing, main

ROOT = Path(__file__).resolve().parents[2]
HEAVY = ("sklearn", "trimesh", "servo.task.evaluation", "scripts.manifold.reproduce")


def test_help_imports_no_experiment():
    """``topomap --help`` built the experiments' parsers by importing them (scikit-learn,
    trimesh, the controllers: ~3 s); now it lists their names and help only."""
    code = (
        "import sys\n"
        "from scripts.cli import build_parser\n"
        "build_parser('').format_help()\n"
        f"print(','.join(m for m in {HEAVY!r} if m in sys.modules))\n"
    )
    out = subprocess.run(
        [sys.executable, "-c", code], cwd=ROOT, capture_output=True, text=True, check=True
    )
    assert out.stdout.strip() == ""


@pytest.mark.parametrize(
    ("command", "option"),
    [("reproduce", "--clusters"), ("group-eval", "--carmen"), ("servo-eval", "--policy")],
)
def test_each_subcommand_still_has_its_options(command, option, capsys):
    with pytest.raises(SystemExit) as done:
        main([command, "--help"])
    assert done.value.code == 0
    assert option in capsys.readouterr().out
    # the whole parser (no command given) has them too, as before
    sub = next(a for a in build_parser()._actions if a.dest == "command")
    assert option in sub.choices[command].format_help()


def _listed(help_text: str) -> dict[str, str]:
    """name -> help of the lines under "commands:" in ``topomap --help``."""
    block = help_text.split("\ncommands:\n", 1)[1].split("\n\n", 1)[0]
    return dict(line.strip().split(None, 1) for line in block.splitlines())


def test_help_lists_every_subcommand_with_its_one_line_help(capsys):
    with pytest.raises(SystemExit) as done:
        main(["--help"])
    assert done.value.code == 0
    listed = _listed(capsys.readouterr().out)
    sub = next(a for a in build_parser("")._actions if a.dest == "command")
    assert list(listed) == list(sub.choices)  # every one, in the order registered
    assert len(listed) == 13
    assert listed["heldout"].startswith("clustering and grouping on held-out")
    assert listed["manifold-eval"].startswith("any scikit-learn clusterer")
    assert listed["leaderboard"].startswith("rank result files per task and protocol")
    assert listed["run"] == "the main job end to end on the default worlds"
    assert listed["sweep"] == "evaluation sweep over worlds, seeds and settings, in parallel"
    assert listed["servo-compare"] == "two servo-eval results, episode by episode"
    assert all(listed.values())


def test_the_listing_follows_the_registered_subparsers():
    parser = argparse.ArgumentParser()
    sub = parser.add_subparsers()
    sub.add_parser("alpha", help="the first")
    sub.add_parser("a-longer-name", help="the second")
    sub.add_parser("bare")
    assert command_listing(sub).splitlines() == [
        "  alpha          the first",
        "  a-longer-name  the second",
        "  bare",  # listed too, though argparse's own list leaves it out
    ]
