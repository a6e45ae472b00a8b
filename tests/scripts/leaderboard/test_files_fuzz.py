"""Seeded fuzz of result files through ``topomap leaderboard``'s reading and ranking: a member
of odd type, a huge integer, a huge or non-finite number, a missing key, a special file in
place of a result: each refused with a ResultFileError naming the file and the field, or
ranked into a table of finite numbers; never a raw exception, never ``inf%``."""

import json
import os

import numpy as np
import pytest

from scripts.leaderboard import ResultFileError, envelope, leaderboard_markdown, load_results
from scripts.leaderboard.files import MAX_VALUE
from tests.fuzz.harness import odd_member
from tests.sim.readers.fuzzing import budget

CASES = 150
ODD_VALUES = (
    None,
    True,
    False,
    -1,
    0,
    2,
    10**400,
    -(10**400),
    1e308,
    -1e308,
    1e13,
    float("nan"),
    float("inf"),
    "x",
    "",
    [],
    ["error"],
    {},
    {"a": None},
    [[[[]]]],
    "9" * 400,
    0.5,
)


def _result() -> dict:
    records = [
        {"group": "g", "unit": f"seed {i}", "value": 0.1 * i, "failure": None} for i in range(4)
    ] + [{"group": "g", "unit": "seed 9", "value": None, "failure": "ValueError: no"}]
    method = {"name": "M", "spec": "pkg.mod:M", "params": {"k": 3}, "notes": "a note"}
    return json.loads(
        json.dumps(envelope("task", ("proto", 2), "test", method, ("err", "error"), records))
    )


def _ranked(path) -> str:
    text = leaderboard_markdown(load_results([path]), reference="M")
    assert "inf" not in text and "nan" not in text.lower(), text
    return text


@pytest.mark.parametrize("seed", [0, 1])
def test_odd_members_are_refused_naming_the_file_or_ranked(tmp_path, seed):
    rng = np.random.default_rng(seed)
    outcomes = {"refused": 0, "ranked": 0}
    escaped = []
    for case in range(CASES):
        data = _result()
        where = odd_member(data, rng, ODD_VALUES)
        path = tmp_path / f"case{case}.json"
        path.write_text(json.dumps(data))
        try:
            with budget(5):
                _ranked(path)
            outcomes["ranked"] += 1
        except ResultFileError as err:
            assert str(path) in str(err), (where, err)
            assert len(str(err)) < 600, (where, err)  # a 400-digit integer is cut short
            outcomes["refused"] += 1
        except Exception as err:  # what the fuzz looks for
            escaped.append(f"{where}: {type(err).__name__}: {err}"[:300])
    assert not escaped, "\n".join(escaped)
    assert outcomes["refused"] > 20 and outcomes["ranked"] > 10, outcomes


@pytest.mark.parametrize(
    ("change", "field"),
    [
        (lambda d: d["method"].update(notes=3), "method.notes: expected a string or null"),
        (lambda d: d["metric"].update(kind=["error"]), "metric: expected"),
        (lambda d: d["records"][0].pop("failure"), r"records\[0\].failure: missing"),
        (lambda d: d["records"][0].pop("value"), r"records\[0\].value: missing"),
        (
            lambda d: d["records"][0].update(value=10**400),
            r"records\[0\].value: .*got 10000+\.\.\.",
        ),
        (lambda d: d["records"][0].update(value=1e308), r"records\[0\].value: .*at most 1e\+12"),
        (lambda d: d["records"][0].update(value=-1e308), r"records\[0\].value"),
        (lambda d: d["protocol"].update(version=10**400), "protocol: expected"),
    ],
)
def test_each_odd_kind_is_refused_naming_the_field(tmp_path, change, field):
    data = _result()
    change(data)
    path = tmp_path / "bad.json"
    path.write_text(json.dumps(data))
    with pytest.raises(ResultFileError, match=field) as err:
        load_results([path])
    assert str(path) in str(err.value)


def test_values_at_the_bound_are_ranked(tmp_path):
    data = _result()
    data["metric"]["kind"] = "score"
    data["records"][0]["value"] = MAX_VALUE
    data["records"][1]["value"] = -(10**12)  # an integer at the bound
    path = tmp_path / "r.json"
    path.write_text(json.dumps(data))
    assert "| M(k=3) |" in _ranked(path)


@pytest.mark.parametrize("special", ["pipe", "link to a device"])
def test_special_files_are_refused_without_blocking(tmp_path, special):
    path = tmp_path / "r.json"
    if special == "pipe":
        os.mkfifo(path)
    else:
        path.symlink_to("/dev/zero")
    for given in (path, tmp_path):  # named, or found in a folder
        with budget(5), pytest.raises(ResultFileError, match="not a regular file") as err:
            load_results([given])
        assert str(path) in str(err.value)


def test_the_command_names_the_file_and_field_without_a_traceback(tmp_path, capsys):
    from scripts.cli import main

    data = _result()
    data["records"][2]["value"] = 10**400
    path = tmp_path / "r.json"
    path.write_text(json.dumps(data))
    assert main(["leaderboard", str(path)]) == 2
    err = capsys.readouterr().err
    assert f"{path}: records[2].value: expected a finite number" in err
    assert "Traceback" not in err
