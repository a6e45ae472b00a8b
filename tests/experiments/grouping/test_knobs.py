"""The knob sweep of the grouping: cropping, the dev criterion and its
guard, and a full small sweep on the synthetic office (two rooms' worth of scans)."""

import json

import numpy as np
import pytest

from experiments.grouping import knobs as gk
from mapping.grouping import office_path, office_world, raycast


def test_crop_keeps_the_view_and_the_range():
    pts = np.array([[1.0, 0.0], [0.0, 1.0], [-1.0, 0.0], [0.5, 0.5], [8.0, 0.1]])
    np.testing.assert_array_equal(gk.crop(pts, fov_deg=90), pts[[0, 3, 4]])
    np.testing.assert_array_equal(gk.crop(pts, fov_deg=180, range_cap=5.0), pts[[0, 1, 3]])
    assert len(gk.crop(pts, fov_deg=360)) == len(pts)


def test_settings_move_one_knob_at_a_time():
    todo = gk.settings()
    assert todo[0] == ("defaults", None, gk.DEFAULTS)
    for knob, value, setting in todo[1:]:
        assert setting[knob] == value != gk.DEFAULTS[knob]
        assert {k: v for k, v in setting.items() if k != knob} == {
            k: v for k, v in gk.DEFAULTS.items() if k != knob
        }
    assert len(todo) == 1 + sum(len(v) - 1 for v in gk.KNOBS.values())


def _row(role, ari=None, rate=0.5):
    score = {"localisation": {"rate": rate, "rate_ci95": [rate - 0.1, rate + 0.1]}}
    if ari is not None:
        score["ari"] = ari
    return {"role": role, "score": score}


def test_dev_score_is_world_ari_guarded_by_the_logs():
    rows = {"w": _row("dev", ari=0.6), "log": _row("dev", rate=0.5), "t": _row("test", ari=0.0)}
    floors = gk.floors_of(rows)
    assert floors == {"log": pytest.approx(0.4)}
    assert gk.dev_score(rows, floors) == pytest.approx(0.6)  # test rows never count
    worse = {**rows, "log": _row("dev", rate=0.3)}  # local maps got worse on the dev log
    assert gk.dev_score(worse, floors) == -np.inf
    missing = {**rows, "w": {"role": "dev", "score": None}}  # e.g. 360 degrees on a log
    assert np.isnan(gk.dev_score(missing, floors))


def test_sweep_on_a_synthetic_office(tmp_path, monkeypatch):
    # two values a knob keep the run short; the logic is the same for the full grid
    small = {"match_distance": (0.1, 0.3), "range_cap": (None, 5.0), "fov_deg": (180, 360)}
    monkeypatch.setattr(gk, "KNOBS", {**small, "threshold": (0.8, 1.0)})
    world = office_world()
    poses = office_path(world, step=0.6)[:60]
    scans = raycast(world.segments, poses)
    wide = raycast(world.segments, poses, n_beams=361, fov=2 * np.pi)
    labels = (poses[:, 0] > np.median(poses[:, 0])).astype(int)
    groups = np.zeros(len(poses), dtype=int)
    cases = [
        gk.Case("office", "dev", scans, poses, groups, labels, wide),
        gk.Case("office log", "dev", scans, poses, groups),  # unlabelled, no 360 degrees
    ]
    result = gk.evaluate_knobs(cases, tmp_path, progress=False)
    assert json.loads((tmp_path / gk.JSON_FILE).read_text()) == json.loads(json.dumps(result))
    wide_row = result["settings"]["fov_deg=360"]["rows"]
    assert wide_row["office log"]["score"] is None and wide_row["office"]["score"] is not None
    assert len(result["dev_grid"]) == len(gk.KNOBS["match_distance"]) * len(gk.KNOBS["threshold"])
    chosen = result["chosen"]
    assert set(chosen) == set(gk.DEFAULTS)
    assert chosen["fov_deg"] == gk.DEFAULTS["fov_deg"] and chosen["range_cap"] is None
    best = max(result["dev_grid"], key=lambda g: g["dev_score"])
    if chosen != gk.DEFAULTS:  # a move off the defaults is the grid's best, by MIN_GAIN
        assert chosen == best["setting"]
        assert best["dev_score"] > result["settings"]["defaults"]["dev_score"] + gk.MIN_GAIN
    text = gk.format_report(result)
    assert "office (dev)" in text and "n/a" in text and "chosen" in text


def test_cases_need_distinct_names(tmp_path):
    case = gk.Case("same", "dev", [np.zeros((0, 2))], np.zeros((1, 3)), np.zeros(1, dtype=int))
    with pytest.raises(ValueError, match="distinct names"):
        gk.evaluate_knobs([case, case], tmp_path, progress=False)
