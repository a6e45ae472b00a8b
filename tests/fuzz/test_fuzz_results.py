"""The harness on result files, read and ranked as ``topomap leaderboard`` does, and through
the command itself: odd members at any depth, huge integers and numbers, NaN and infinity,
truncated and flipped bytes, deep nesting, special files, in a file named or in a folder.
Each gives a ResultFileError naming the file or a table of finite numbers (the command: exit
status 2 with the file named and no traceback, or 0)."""

import contextlib
import io
import json
import math

import numpy as np
import pytest

from scripts.cli import main
from scripts.leaderboard import ResultFileError, leaderboard_markdown, load_results
from tests.fuzz.harness import (
    ODD_VALUES,
    SPECIAL_FILES,
    Judge,
    case_count,
    flipped,
    odd_member,
    special_file,
    truncated,
)
from tests.scripts.leaderboard.test_files_fuzz import _result

KINDS = (
    "member",
    "member",
    "value",
    "truncated",
    "flipped",
    "nesting",
    "special file",
    "folder",
    "rate",
)
VALUES = (
    1e308,
    -1e308,
    1e12,
    1e13,
    10**400,
    -(10**13),
    float("nan"),
    float("inf"),
    5e-324,
    -0.0,
    True,
    "0.5",
)


def _ranked(path) -> str:
    return leaderboard_markdown(load_results([path]))


def _valid(text: str) -> None:
    """Every number the table shows (not the method's parameters or notes) is finite."""
    rows = [
        line.strip("|").split(" | ")
        for line in text.splitlines()
        if line[:2] == "| " and line[2:3].isdigit()
    ]
    assert rows, f"no ranked row: {text[:300]}"
    for cells in rows:
        shown = " ".join([cells[0], *cells[2:-1]])
        for word in ("inf", "nan", "e+"):
            assert word not in shown.lower(), f"the table shows {word!r}: {shown}"
        for cell in shown.replace("[", " ").replace("]", " ").replace(",", " ").split():
            with contextlib.suppress(ValueError):
                value = float(cell.rstrip("%"))
                assert math.isfinite(value) and abs(value) < 1e15, cell


def _case(path, kind, rng):
    data = _result()
    if kind == "member":
        odd_member(data, rng, ODD_VALUES)
    elif kind == "value":
        data["records"][int(rng.integers(4))]["value"] = VALUES[int(rng.integers(len(VALUES)))]
    elif kind == "rate":
        data["metric"]["kind"] = "rate"
        for r in data["records"][:4]:
            r["value"] = bool(rng.random() < 0.5)
        data["records"][int(rng.integers(4))]["value"] = VALUES[int(rng.integers(len(VALUES)))]
    text = json.dumps(data).encode()
    if kind == "truncated":
        text = truncated(text, rng)
    elif kind == "flipped":
        text = flipped(text, rng, int(rng.integers(1, 4)))
    elif kind == "nesting":
        depth = int(rng.choice([1000, 100_000]))
        text = text.replace(b'"notes": "a note"', b'"notes": ' + b"[" * depth + b"]" * depth)
    path.write_bytes(text)


@pytest.mark.parametrize("seed", [0, 1])
def test_every_kind_of_damage_gives_a_result_file_error_or_a_finite_table(tmp_path, seed):
    rng = np.random.default_rng(300 + seed)
    judge = Judge(_ranked, ResultFileError, _valid, seconds=5.0)
    n = case_count(70) // 2
    for case in range(n):
        kind = KINDS[case % len(KINDS)]
        folder = tmp_path / f"case{case}"
        folder.mkdir()
        path = folder / "r.json"
        if kind in ("special file", "folder"):
            _case(folder / "other.json", "value", rng)
            # not "folder": a folder named is read as the folder of results it is
            specials = [s for s in SPECIAL_FILES if s != "folder"]
            special_file(path, specials[case % len(specials)])
        else:
            _case(path, kind, rng)
        given = folder if kind == "folder" else path
        outcome = judge(kind, given, names=path if kind != "folder" else folder)
        if case % 4 == 0:  # and through the public command
            _through_the_command(judge, kind, given, path, outcome)
    judge.assert_clean(least=n)


def _through_the_command(judge, kind, given, path, outcome):
    err = io.StringIO()
    try:
        with contextlib.redirect_stderr(err), contextlib.redirect_stdout(io.StringIO()):
            status = main(["leaderboard", str(given)])
    except Exception as exc:  # what the fuzz looks for
        judge.escapes.append(f"{kind}: topomap leaderboard raised {type(exc).__name__}: {exc}")
        return
    expected = 0 if outcome == "read" else 2
    if status != expected or "Traceback" in err.getvalue():
        judge.escapes.append(f"{kind}: topomap leaderboard exit {status}: {err.getvalue()[:300]}")
    elif status == 2 and str(path) not in err.getvalue() and str(given) not in err.getvalue():
        judge.escapes.append(f"{kind}: topomap leaderboard names no file: {err.getvalue()[:300]}")
