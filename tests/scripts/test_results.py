"""``python -m scripts.results``: README's Results table and the results pages are what the
committed result files give, and a number changed on either side is caught."""

import json
import re
import shutil
from pathlib import Path

import pytest

from scripts.results import ROWS, generate, main, read_estimate
from scripts.results.render import DATA, END, FRONT_PAGE, HELDOUT_END, HELDOUT_START, START

ROOT = Path(__file__).resolve().parents[2]


@pytest.fixture
def copy(tmp_path):
    """README.md, the docs' front page and docs/results/ copied, to be tampered with."""
    shutil.copy(ROOT / "README.md", tmp_path / "README.md")
    shutil.copytree(ROOT / "docs" / "results", tmp_path / "docs" / "results")
    shutil.copy(ROOT / "docs" / "index.md", tmp_path / "docs" / "index.md")
    return tmp_path


def test_the_repository_is_up_to_date(capsys):
    assert main(["--check"]) == 0, capsys.readouterr().err


def test_every_row_reads_an_estimate_inside_its_interval():
    for row in ROWS:
        e = read_estimate(ROOT / DATA, row.reader, row.source, **row.keys)
        assert e.n >= 1
        if e.interval is not None:
            assert e.interval[0] <= e.value <= e.interval[1], row


def test_a_number_edited_in_readme_is_caught(copy, capsys):
    readme = copy / "README.md"
    text = readme.read_text()
    table = text[text.index(START) : text.index(END)]
    assert "| 89.0% [81.4%, 93.7%] |" in table  # SignalServo, hallway, anywhere: 89/100
    readme.write_text(text.replace("| 89.0% [81.4%, 93.7%] |", "| 90.0% [81.4%, 93.7%] |"))
    assert main(["--check", "--root", str(copy)]) == 1
    assert "README.md" in capsys.readouterr().err


def test_a_changed_result_file_makes_readme_and_page_stale(copy, capsys):
    path = copy / DATA / "servo" / "signal-hallway-anywhere-test-100ep.json"
    data = json.loads(path.read_text())
    data["results"][0]["successes"] -= 1  # a servo-eval result file keeps its results inside
    path.write_text(json.dumps(data))
    assert main(["--check", "--root", str(copy)]) == 1
    stale = capsys.readouterr().err
    assert "README.md" in stale and "docs/results/servo.md" in stale
    assert "docs/results/manifold-clustering.md" not in stale
    assert main(["--root", str(copy)]) == 0  # regenerated: 88/100 now, and consistent
    assert "| 88.0% [80.2%, 93.0%] |" in (copy / "README.md").read_text()
    assert main(["--check", "--root", str(copy)]) == 0


def test_the_front_page_shows_readme_table_with_its_links_from_docs(copy, capsys):
    readme, front = (ROOT / "README.md").read_text(), (ROOT / FRONT_PAGE).read_text()
    table = readme[readme.index(START) : readme.index(END)]
    assert front[front.index(START) : front.index(END)] == table.replace(
        "](docs/results/", "](results/"
    )
    page = copy / FRONT_PAGE
    edited = page.read_text().replace("| 89.0% [81.4%, 93.7%] |", "| 90.0% [81.4%, 93.7%] |")
    page.write_text(edited)
    assert main(["--check", "--root", str(copy)]) == 1
    assert "docs/index.md" in capsys.readouterr().err


def test_readme_states_no_result_outside_its_generated_tables():
    """A percentage in README's prose would be a number no result file keeps up to date: the
    results are the generated tables' (and their pages')."""
    text = (ROOT / "README.md").read_text()
    for start, end in ((START, END), (HELDOUT_START, HELDOUT_END)):
        text = text[: text.index(start)] + text[text.index(end) :]
    # "95% interval" names the interval a result is given with, not a result
    stated = [
        line for line in text.splitlines() if re.search(r"\d%", line.replace("95% interval", ""))
    ]
    assert not stated, "README states results outside its generated tables:\n" + "\n".join(stated)


def test_readme_without_its_markers_is_refused(copy):
    readme = copy / "README.md"
    readme.write_text(readme.read_text().replace(END, ""))
    with pytest.raises(ValueError, match="results:end"):
        generate(copy)


def test_a_file_without_its_provenance_is_refused(copy):
    meta = copy / DATA / "grouping" / "meta.json"
    entries = json.loads(meta.read_text())
    del entries["radish-logs.json"]["commit"]
    meta.write_text(json.dumps(entries))
    with pytest.raises(ValueError, match="lacks"):
        generate(copy)


def test_a_changed_held_out_cell_makes_readme_and_its_page_stale(copy, capsys):
    path = copy / DATA / "worlds" / "heldout.json"
    data = json.loads(path.read_text())
    cell = next(c for c in data["cells"] if ":" in c["world"] and "grouping" in c["tasks"])
    cell["tasks"]["grouping"]["purity"] = 0.0  # the summary is recomputed from the cells
    path.write_text(json.dumps(data))
    assert main(["--check", "--root", str(copy)]) == 1
    stale = capsys.readouterr().err
    assert "README.md" in stale and "docs/results/held-out-worlds.md" in stale
    assert "docs/results/servo.md" not in stale


def test_a_held_out_file_without_cells_is_refused(copy):
    path = copy / DATA / "worlds" / "heldout.json"
    path.write_text(json.dumps({"summary": {}, "cells": []}))
    with pytest.raises(ValueError, match="heldout.json: 'cells' must be a non-empty list"):
        generate(copy)
    readme = copy / "README.md"
    readme.write_text(readme.read_text().replace("<!-- heldout:end -->", ""))
    path.write_text(
        json.dumps({"cells": [{"world": "lawn", "family": "lawn", "frames": 150, "tasks": {}}]})
    )
    with pytest.raises(ValueError, match="heldout:end"):
        generate(copy)
