"""``servo.task.paired_comparison`` / ``topomap servo-compare``: two evaluations paired episode by
episode, and the result files read as untrusted input."""

import json
from pathlib import Path

import numpy as np
import pytest
from scipy import stats

from scripts.cli import main
from servo.task import paired_comparison as cmp

RESULTS = Path(__file__).resolve().parents[3] / "docs" / "results" / "data" / "servo"


def _result(wins, world="hallway", starts=None, seeds=None, **setting):
    base = dict(
        world=world,
        tier="anywhere",
        split="test",
        randomize=False,
        odometry_noise=True,
        max_steps=600,
        policy="signal",
    )
    base.update(setting)
    starts = starts or ["hallway"] * len(wins)
    seeds = seeds or [100 + i for i in range(len(wins))]
    base["episodes_detail"] = [
        {"episode": i, "seed": s, "success": bool(w), "start_manifold": m}
        for i, (w, s, m) in enumerate(zip(wins, seeds, starts, strict=True))
    ]
    return base


def _write(path, obj):
    path.write_text(json.dumps(obj))
    return path


def test_paired_counts_sign_test_and_bootstrap():
    a = [_result([1, 1, 0, 0, 1, 0], starts=["m", "m", "m", "b", "b", "b"])]
    b = [_result([1, 0, 1, 1, 1, 1, 0], starts=["m", "m", "m", "b", "b", "b", "b"])]
    (row,) = cmp.compare(a, b)
    assert (row.n, row.successes_a, row.successes_b) == (6, 3, 5)  # B's 7th has no pair
    assert (row.gained, row.lost) == (3, 1)
    assert row.sign_test_p == pytest.approx(stats.binomtest(3, 4, 0.5).pvalue)
    assert row.difference == pytest.approx(2 / 6)
    lo, hi = row.difference_ci95
    assert lo < row.difference < hi and -1 <= lo and hi <= 1
    assert row.difference_ci95 == cmp.compare(a, b)[0].difference_ci95  # default rng: seeded
    assert row.by_start == {"b": (3, 1, 3), "m": (3, 2, 2)}
    assert "+3 / -1" in cmp.markdown([row])


def test_only_shared_settings_are_compared_and_seeds_must_agree():
    a = [_result([1, 0]), _result([1, 1], world="lawn")]
    b = [_result([0, 0], world="lawn"), _result([1, 1], randomize=True)]
    (row,) = cmp.compare(a, b)
    assert row.setting["world"] == "lawn" and (row.gained, row.lost) == (0, 2)
    with pytest.raises(ValueError, match="seed"):
        cmp.compare([_result([1, 0])], [_result([1, 0], seeds=[100, 7])])
    with pytest.raises(TypeError, match="Generator"):
        cmp.compare(a, b, rng=0)
    with pytest.raises(ValueError, match="resamples"):
        cmp.compare(a, b, resamples=0)


def test_result_files_are_checked(tmp_path):
    good = _write(tmp_path / "a.json", [_result([1, 0])])
    assert cmp.load_results(good)[0]["world"] == "hallway"
    assert len(cmp.load_results(_write(tmp_path / "one.json", _result([1])))) == 1
    with pytest.raises(ValueError, match="not a file"):
        cmp.load_results(tmp_path / "missing.json", "A")
    (tmp_path / "bad.json").write_text("{not json")
    with pytest.raises(ValueError, match="not JSON"):
        cmp.load_results(tmp_path / "bad.json")
    broken = _result([1, 0])
    del broken["split"]
    with pytest.raises(ValueError, match="'split'"):
        cmp.load_results(_write(tmp_path / "c.json", [broken]))
    twice = _result([1, 0])
    twice["episodes_detail"][1]["episode"] = 0
    with pytest.raises(ValueError, match="twice"):
        cmp.load_results(_write(tmp_path / "d.json", [twice]))
    for field, value in (("success", 1), ("seed", "7"), ("episode", -1), ("episode", True)):
        bad = _result([1])
        bad["episodes_detail"][0][field] = value
        with pytest.raises(ValueError, match=r"B\[0\]\.episodes_detail\[0\]"):
            cmp.load_results(_write(tmp_path / "e.json", [bad]), "B")
    with pytest.raises(ValueError, match="non-empty list"):
        cmp.load_results(_write(tmp_path / "f.json", []))


def test_result_files_over_the_size_limit_are_refused(tmp_path, monkeypatch):
    path = _write(tmp_path / "a.json", [_result([1, 0])])
    monkeypatch.setattr(cmp, "MAX_BYTES", 16)
    with pytest.raises(ValueError, match="larger than"):
        cmp.load_results(path)


def test_cli_on_the_committed_results(capsys):
    """The two controllers on the committed test cells: on the hallway's 100 ``anywhere``
    episodes ``ManifoldServo`` (96) against ``SignalServo`` (89); a two-world file against a
    lawn-only one pairs the lawn alone."""
    signal = RESULTS / "signal-hallway-anywhere-test-100ep.json"
    servo = RESULTS / "servo-hallway-anywhere-test-100ep.json"
    assert main(["servo-compare", str(signal), str(servo)]) == 0
    out = capsys.readouterr().out
    assert "| hallway | anywhere | test | 600 steps | 100 | 89 | 96 | +10 / -3 |" in out
    both = RESULTS / "servo-all-view-test-100ep.json"
    lawn = RESULTS / "signal-lawn-view-test-100ep.json"
    assert main(["servo-compare", str(lawn), str(both), "--json"]) == 0
    rows = json.loads(capsys.readouterr().out)
    paired = [(r["setting"]["world"], r["n"], r["gained"], r["lost"]) for r in rows]
    assert paired == [("lawn", 100, 10, 0)]


def test_cli_refuses_files_without_shared_episodes(tmp_path, capsys):
    a = _write(tmp_path / "a.json", [_result([1, 0])])
    b = _write(tmp_path / "b.json", [_result([1, 0], world="lawn")])
    assert main(["servo-compare", str(a), str(b)]) == 2
    assert "share no world" in capsys.readouterr().err
    assert np.isfinite(cmp.compare([_result([1])], [_result([0])])[0].sign_test_p)


def test_result_files_nested_past_the_parser_are_refused(tmp_path):
    """100 000 '[' make json.loads raise RecursionError: a ValueError naming the file."""
    path = tmp_path / "deep.json"
    path.write_text("[" * 100_000)
    with pytest.raises(ValueError, match=r"B: .*deep\.json is not JSON"):
        cmp.load_results(path, "B")


def test_no_discordant_pair_has_sign_test_p_one():
    (row,) = cmp.compare([_result([1, 0])], [_result([1, 0])])
    assert (row.gained, row.lost, row.sign_test_p) == (0, 0, 1.0)
    assert row.difference_ci95 == (0.0, 0.0)


def test_the_default_generator_is_seed_zero():
    # 41 episodes and 50 resamples: the interval's ends fall between resample means
    a = [_result([i % 3 == 0 for i in range(41)])]
    b = [_result([i % 2 == 0 for i in range(41)])]
    given = cmp.compare(a, b, np.random.default_rng(0), resamples=50)[0].difference_ci95
    assert cmp.compare(a, b, resamples=50)[0].difference_ci95 == given
    assert cmp.compare(a, b, np.random.default_rng(1), resamples=50)[0].difference_ci95 != given


def test_argument_and_seed_errors_say_what_is_wrong():
    a = [_result([1, 0])]
    with pytest.raises(TypeError, match="^rng must be a numpy.random.Generator, got int$"):
        cmp.compare(a, a, rng=0)
    with pytest.raises(ValueError, match="^resamples must be an integer"):
        cmp.compare(a, a, resamples=0)
    with pytest.raises(ValueError, match=r"not the same episodes \(another protocol version\?\)$"):
        cmp.compare(a, [_result([1, 0], seeds=[100, 7])])


def test_malformed_results_are_named(tmp_path):
    with pytest.raises(ValueError, match="^results: .* is not a file$"):
        cmp.load_results(tmp_path / "missing.json")
    cases = [
        ([3], r"^R\[0\]: expected an object, got int$"),
        ([_result([1], tier=7)], r"^R\[0\]: 'world' and 'tier' must be strings$"),
        ([{**_result([1]), "episodes_detail": {}}], r"^R\[0\]: 'episodes_detail' must be a list"),
        ([{**_result([1]), "episodes_detail": [5]}], r"^R\[0\]\.episodes_detail\[0\]: expected an"),
    ]
    for data, match in cases:
        with pytest.raises(ValueError, match=match):
            cmp.load_results(_write(tmp_path / "r.json", data), "R")


def test_a_file_of_exactly_the_size_limit_is_read(tmp_path, monkeypatch):
    monkeypatch.setattr(cmp, "MAX_BYTES", 2 << 20)
    text = json.dumps([_result([1, 0])])
    path = tmp_path / "a.json"
    path.write_text(text + " " * ((2 << 20) - len(text)))
    assert len(cmp.load_results(path)) == 1
    path.write_text(text + " " * ((2 << 20) - len(text) + 1))
    with pytest.raises(ValueError, match="is larger than 2 MB$"):
        cmp.load_results(path)


def test_markdown_table():
    a = [_result([1, 0, 0], starts=["m", "b", "b"], randomize=True, odometry_noise=False)]
    b = [_result([1, 1, 0], starts=["m", "b", "b"], randomize=True, odometry_noise=False)]
    rows = cmp.compare(a, b)
    lo, hi = rows[0].difference_ci95
    assert cmp.markdown(rows).split("\n") == [
        "| world | tier | split | settings | episodes | A | B | gained / lost by B | "
        "sign test p | B - A [95% bootstrap] | by start manifold (A / B) |",
        "|---|---|---|---|---|---|---|---|---|---|---|",
        "| hallway | anywhere | test | 600 steps, randomize, no odometry noise | 3 | 1 | 2 | "
        f"+1 / -0 | 1 | +0.333 [{lo:+.3f}, {hi:+.3f}] | b 0/1 of 2; m 1/1 of 1 |",
    ]
    assert lo < hi
