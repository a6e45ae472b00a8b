"""The ``topomap`` command line: its help is quick to show, every subcommand's options stay."""

from __future__ import annotations

import subprocess
import sys
from pathlib import Path

import pytest

from scripts.cli import build_parser, main

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
    out = subprocess.run([sys.executable, "-c", code], cwd=ROOT, capture_output=True, text=True,
                         check=True)  # fmt: skip
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
