"""Every study under ``experiments/`` runs as ``python -m experiments.<area>.<name>``: its
imports resolve against the current packages and its command line parses (``--help``)."""

from __future__ import annotations

import runpy
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[2]
STUDIES = sorted(
    ".".join(p.relative_to(ROOT).with_suffix("").parts)
    for p in (ROOT / "experiments").glob("*/*.py")
    if p.name != "__init__.py"
)


def test_the_studies_are_found():
    assert len(STUDIES) >= 15
    assert {s.split(".")[1] for s in STUDIES} == {"manifold", "grouping", "servo", "heldout"}


@pytest.mark.parametrize("study", STUDIES)
def test_a_study_runs_as_a_module(study, monkeypatch, capsys):
    monkeypatch.setattr(sys, "argv", [study, "--help"])
    monkeypatch.delitem(sys.modules, study, raising=False)  # another study may import it
    with pytest.raises(SystemExit) as done:
        runpy.run_module(study, run_name="__main__", alter_sys=False)
    assert done.value.code == 0
    assert "usage:" in capsys.readouterr().out
