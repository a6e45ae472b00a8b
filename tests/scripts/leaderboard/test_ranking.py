"""The leaderboard: ranks within a board and group, intervals of the right kind, paired tests
against the reference, and refuses to mix protocol versions."""

import numpy as np
import pytest

from scripts.cli import main as cli_main
from scripts.leaderboard import envelope, leaderboard_html, load_results, rank, write_result


def _write(folder, name, values, kind="error", version=1, failures=(), group="g"):
    records = [
        {
            "group": group,
            "unit": f"seed {i}",
            "value": None if i in failures else v,
            "failure": "RuntimeError: x" if i in failures else None,
        }
        for i, v in enumerate(values)
    ]
    result = envelope(
        "task", ("proto", version), "test", {"name": name, "params": {}}, ("err", kind), records
    )
    return write_result(folder / f"{name}-v{version}.json", result)


def test_errors_rank_lowest_first_with_bootstrap_intervals_and_paired_tests(tmp_path):
    rng = np.random.default_rng(1)
    base = rng.uniform(0.1, 0.3, 12)
    _write(tmp_path, "good", base - 0.05)
    _write(tmp_path, "ref", base)
    _write(tmp_path, "bad", base + 0.05, failures=(3,))
    (tmp_path / "notes.json").write_text('{"other": 1}')  # foreign JSON in a folder: passed over
    boards = rank(load_results([tmp_path]), reference="ref")
    (rows,) = boards.values()
    good, ref, bad = rows["g"]
    assert [good.method, ref.method, bad.method] == ["good", "ref", "bad"]
    assert good.lo <= good.mean <= good.hi and good.lo < good.hi
    assert good.paired["diff"] == pytest.approx(-0.05) and good.paired["p"] < 0.01
    assert bad.failed == 1 and bad.paired["n"] == 11  # the failed seed is in no test
    assert ref.paired == {}


def test_rates_get_wilson_intervals_and_mcnemar(tmp_path):
    _write(tmp_path, "always", [True] * 20, kind="rate")
    _write(tmp_path, "half", [i % 2 == 0 for i in range(20)], kind="rate")
    (rows,) = rank(load_results([tmp_path]), reference="half").values()
    always, half = rows["g"]
    assert half.mean == 0.5 and half.paired == {}
    assert always.mean == 1.0 and 0.8 < always.lo < 1.0 and always.hi == pytest.approx(1.0)
    assert "McNemar" in always.paired["test"]
    assert always.paired["p"] == pytest.approx(2 * 0.5**10)  # 10 discordant, all one way
    assert always.paired["lo"] <= always.paired["diff"] == 0.5 <= always.paired["hi"]


def test_other_protocol_versions_are_refused_not_mixed(tmp_path):
    _write(tmp_path, "a", [0.1, 0.2], version=1)
    _write(tmp_path, "b", [0.1, 0.2], version=2)
    with pytest.raises(ValueError, match="different protocol versions are not comparable"):
        rank(load_results([tmp_path]))


def test_a_reference_must_name_one_method(tmp_path):
    _write(tmp_path, "a", [0.1, 0.2])
    with pytest.raises(ValueError, match="names no method"):
        rank(load_results([tmp_path]), reference="zzz")


def test_files_of_one_method_are_joined_and_a_unit_twice_is_refused(tmp_path):
    one, two = tmp_path / "1", tmp_path / "2"
    one.mkdir(), two.mkdir()
    _write(one, "a", [0.1, 0.2])
    _write(two, "a", [0.1, 0.2])
    with pytest.raises(ValueError, match="already has g seed 0"):
        rank(load_results([one, two]))
    _write(two, "a", [0.3], group="h")
    (rows,) = rank(load_results([one, two])).values()
    assert {g: len(r[0].values) for g, r in rows.items()} == {"g": 2, "h": 1}


def test_the_command_writes_markdown_and_html(tmp_path, capsys):
    _write(tmp_path, "a", [0.1, 0.2, 0.3])
    _write(tmp_path, "b<x>", [0.2, 0.3, 0.4])
    md, page = tmp_path / "out" / "board.md", tmp_path / "out" / "board.html"
    code = cli_main(
        [
            "leaderboard",
            str(tmp_path),
            "--reference",
            "a",
            "--markdown",
            str(md),
            "--html",
            str(page),
        ]
    )
    assert code == 0
    text = md.read_text()
    assert "| 1 | a | 3 | 0 | 20.0% [" in text and "paired vs a" in text
    assert "b&lt;x&gt;" in page.read_text()  # names are escaped in HTML
    assert leaderboard_html(load_results([tmp_path])).startswith("<!doctype html>")
    assert cli_main(["leaderboard", str(tmp_path / "out")]) == 2  # no result files there
    assert "no result files" in capsys.readouterr().err


def test_a_label_shows_the_users_parameters_not_the_protocols():
    from scripts.leaderboard.ranking import method_label

    ours = {"name": "C", "params": {"n_clusters": 8, "eps": 0.5}, "protocol_params": ["n_clusters"]}
    theirs = {"name": "C", "params": {"n_clusters": None}, "protocol_params": []}
    assert method_label(ours) == "C(eps=0.5)"
    assert method_label(theirs) == "C(n_clusters=None)"


def test_few_seeds_or_episodes_and_a_disagreeing_test_are_warned_of(tmp_path):
    from scripts.leaderboard import leaderboard_markdown

    _write(tmp_path, "ref", [0.20, 0.30])
    _write(tmp_path, "two", [0.10, 0.21])  # two seeds: an "interval" of two values, p = 0.5
    _write(tmp_path, "coin", [True] * 6, kind="rate", group="r")
    text = leaderboard_markdown(load_results([tmp_path]), reference="ref")
    assert "only 2 units (fewer than 5)" in text and "too narrow" in text
    assert "interval and test disagree over 2 units" in text
    assert "only 6 episodes (fewer than 20)" in text


def test_a_result_file_of_another_method_is_not_replaced(tmp_path):
    from scripts.leaderboard import ResultFileError
    from scripts.leaderboard.files import file_tag

    def method(spec, **params):
        return {"name": "KMeans", "spec": spec, "params": params}

    path = tmp_path / "manifold-KMeans.json"
    records = [{"group": "g", "unit": "seed 1", "value": 0.1, "failure": None}]
    write_result(
        path,
        envelope(
            "t", ("p", 1), "test", method("sklearn.cluster:KMeans"), ("err", "error"), records
        ),
    )
    write_result(
        path,
        envelope(
            "t", ("p", 1), "test", method("sklearn.cluster:KMeans"), ("err", "error"), records
        ),
    )  # the same method: a rerun
    with pytest.raises(ResultFileError, match="sklearn.cluster:KMeans.*refusing.*mine:KMeans"):
        write_result(
            path, envelope("t", ("p", 1), "test", method("mine:KMeans"), ("err", "error"), records)
        )
    # names that cannot meet: the full spec, and the params' digest
    tags = {
        file_tag("sklearn.cluster:KMeans", {}),
        file_tag("mine:KMeans", {}),
        file_tag("mine:KMeans", {"k": 3}),
        file_tag("mine:KMeans", {"k": 4}),
    }
    assert len(tags) == 4 and all(":" not in t for t in tags)


def test_an_unsandboxed_outside_policy_and_its_source_are_shown(tmp_path):
    from scripts.leaderboard import leaderboard_markdown

    records = [
        {"group": "g", "unit": f"episode {i}", "value": True, "failure": None} for i in range(20)
    ]
    source = {"module": "mine", "files": 1, "sha256": "ab" * 32}
    for name, sandboxed in (("mine", False), ("theirs", True)):
        m = {
            "name": name,
            "spec": f"{name}:make",
            "params": {},
            "sandboxed": sandboxed,
            "source": source,
        }
        result = envelope("servo", ("p", 1), "test", m, ("success", "rate"), records)
        write_result(tmp_path / f"{name}.json", result)
    text = leaderboard_markdown(load_results([tmp_path]))
    rows = {line.split("|")[2].strip(): line for line in text.splitlines() if "source" in line}
    assert "NOT sandboxed" in rows["mine"] and "NOT sandboxed" not in rows["theirs"]
    assert "source abababababab" in rows["theirs"]
