"""Result files: what the writer writes the reader reads back; damaged, foreign or
oversized files are refused naming the file and the field."""

import json

import pytest

from scripts.leaderboard import ResultFileError, envelope, read_result, write_result
from scripts.leaderboard import files as rf


def _result(records=None, kind="error", **extra):
    records = (
        records
        if records is not None
        else [
            {"group": "g", "unit": "seed 1", "value": 0.1, "failure": None},
            {"group": "g", "unit": "seed 2", "value": None, "failure": "ValueError: no"},
        ]
    )
    method = {"name": "M", "spec": "pkg.mod:M", "params": {"k": 3}}
    return envelope("task", ("proto", 2), "test", method, ("err", kind), records, **extra)


def test_a_written_file_reads_back_with_its_provenance(tmp_path):
    path = write_result(tmp_path / "r.json", _result(settings={"K": 8}))
    back = read_result(path)
    assert back["protocol"] == {"name": "proto", "version": 2}
    assert back["records"][1]["failure"] == "ValueError: no"
    assert back["settings"] == {"K": 8}
    assert back["machine"]["cores"] >= 1 and back["machine"]["platform"]
    assert set(back["code_version"]) == {"package", "commit"}


@pytest.mark.parametrize(
    ("change", "field"),
    [
        (lambda d: d.pop("protocol"), "protocol: missing"),
        (lambda d: d.update(format="other"), "format: expected"),
        (lambda d: d.update(format_version=99), "format_version: this reader reads version 1"),
        (lambda d: d["protocol"].update(version="1"), "protocol: expected"),
        (lambda d: d["metric"].update(kind="speed"), "metric: expected"),
        (lambda d: d["records"][0].update(value=float("nan")), r"records\[0\].value"),
        (lambda d: d["records"][0].update(value=True), r"records\[0\].value"),
        (lambda d: d["records"].append(dict(d["records"][0])), "appears twice"),
        (lambda d: d["records"][1].update(value=0.2), "a failed record"),
        (lambda d: d["records"][0].pop("unit"), "'group' and 'unit'"),
    ],
)
def test_a_malformed_file_is_refused_naming_the_field(tmp_path, change, field):
    data = json.loads(json.dumps(_result()))
    change(data)
    path = tmp_path / "bad.json"
    path.write_text(json.dumps(data))
    with pytest.raises(ResultFileError, match=field) as err:
        read_result(path)
    assert str(path) in str(err.value)


def test_a_rate_takes_bools_only(tmp_path):
    records = [{"group": "g", "unit": "episode 0", "value": 1, "failure": None}]
    with pytest.raises(ResultFileError, match="true or false"):
        write_result(tmp_path / "r.json", _result(records, kind="rate"))
    assert not (tmp_path / "r.json").exists()  # the writer refuses what its reader would


def test_not_json_and_oversized_files_are_refused_before_use(tmp_path, monkeypatch):
    path = tmp_path / "r.json"
    path.write_bytes(b"\x80 not json")
    with pytest.raises(ResultFileError, match="file: not JSON"):
        read_result(path)
    write_result(path, _result())
    monkeypatch.setattr(rf, "MAX_BYTES", 100)
    with pytest.raises(ResultFileError, match="more than the 100 allowed"):
        read_result(path)


def test_the_envelope_keeps_its_own_keys():
    with pytest.raises(ValueError, match="would replace"):
        _result(records=[], machine={"cores": 1})
    with pytest.raises(ValueError, match="metric kind"):
        envelope("t", ("p", 1), "test", {"name": "m"}, ("x", "speed"), [])
