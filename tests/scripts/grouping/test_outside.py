"""``topomap group-eval --method``: an outside estimator scored on a tiny simulated dataset
and on the shipped slice of a Carmen log; failures recorded, bad input refused."""

import sys

import numpy as np
import pytest

from scripts.cli import main as cli_main
from scripts.grouping import outside
from scripts.grouping.scores import score_groups
from scripts.leaderboard import OutsideMethod, read_result
from sim.camera import CameraConfig
from sim.collect import CollectionSettings, collect_dataset
from sim.dataset import load_dataset

BY_DRIVE = '''
import numpy as np

class ByDrive:
    """One group per drive: the groups the evaluation passes to fit."""
    def fit(self, scans, poses, groups=None):
        self.labels_ = np.asarray(groups, dtype=int)
        return self

class NoLabels:
    def fit(self, scans, poses):
        return self
'''


@pytest.fixture(scope="module")
def data(tmp_path_factory):
    root = tmp_path_factory.mktemp("group_outside")
    settings = CollectionSettings(worlds=("hallway",), frames=12, camera=CameraConfig(32, 24))
    collect_dataset(root / "d", settings, jobs=1, progress=False)
    return root / "d"


@pytest.fixture
def user_module(tmp_path, monkeypatch):
    (tmp_path / "by_drive_mod.py").write_text(BY_DRIVE)
    monkeypatch.chdir(tmp_path)
    monkeypatch.setattr(sys, "path", list(sys.path))


def test_an_estimator_gets_scans_poses_and_drives_and_is_scored_on_the_truth(data, user_module):
    method = OutsideMethod("by_drive_mod:ByDrive", ("fit",))
    (scores,) = outside.evaluate_worlds_method(method, [data], progress=False)
    runs = load_dataset(data).runs("hallway")
    expected = score_groups(runs.labels, runs.groups, runs.manifold_names)
    assert [r["group"] for r in scores["records"]] == list(outside.POSES)
    for r in scores["records"]:
        assert r["unit"] == "seed 0/hallway" and r["failure"] is None
        assert r["value"] == pytest.approx(expected["ari"])
        assert r["purity"] == pytest.approx(expected["purity"])
    assert scores["protocol"]["name"] == outside.PROTOCOLS["worlds"][0]
    assert scores["split"] == "dev"  # seed 0: the dev seed


def test_a_plain_clusterer_on_positions_and_the_local_maps(data):
    method = OutsideMethod("sklearn.cluster:AgglomerativeClustering", ("fit",), {"n_clusters": 2})
    scores, maps = outside.evaluate_worlds_method(
        method, [data], "positions", local_maps=True, progress=False
    )
    assert scores["method"]["input"] == "positions"
    assert all(r["failure"] is None for r in scores["records"])
    assert maps["metric"] == {"name": "localised", "kind": "rate"}
    assert maps["records"] and all(isinstance(r["value"], bool) for r in maps["records"])


def test_a_carmen_log_is_scored_by_held_out_localisation(aces_slice_log):
    method = OutsideMethod("sklearn.cluster:DBSCAN", ("fit",), {"eps": 1.0})
    result = outside.evaluate_carmen_method(method, [aces_slice_log], "positions", progress=False)
    units = [r["unit"] for r in result["records"]]
    assert units and all(u.startswith("aces-every-third-scan/scan ") for u in units)
    assert len(set(units)) == len(units)
    rate = np.mean([r["value"] for r in result["records"]])
    assert 0.0 <= rate <= 1.0
    assert result["protocol"]["name"] == outside.PROTOCOLS["carmen"][0]


def test_an_estimator_without_labels_fails_per_case_and_the_command_goes_on(
    data, user_module, tmp_path, capsys
):
    out = tmp_path / "out"
    code = cli_main(
        [
            "group-eval",
            "--method",
            "by_drive_mod:NoLabels",
            "--data",
            str(data),
            "--out",
            str(out),
            "--quiet",
        ]
    )
    assert code == 0
    (path,) = out.glob("*.json")
    records = read_result(path)["records"]
    assert [r["failure"] for r in records] == ["ValueError: fit left no labels_ attribute"] * 2
    assert "failed: ValueError: fit left no labels_" in capsys.readouterr().out


def test_bad_input_is_one_clear_line(data, tmp_path, capsys):
    argv = ["group-eval", "--data", str(data), "--data", str(data), "--out", str(tmp_path)]
    assert cli_main(argv) == 2
    assert "--data is given once, except with --method" in capsys.readouterr().err
    assert cli_main([*argv, "--method", "sklearn.cluster:DBSCAN"]) == 2
    assert "are both of seed 0: give each dataset seed once" in capsys.readouterr().err
    assert cli_main([*argv, "--method", "sklearn.cluster:DBSCAN", "--param", "eps"]) == 2
    assert "KEY=VALUE" in capsys.readouterr().err
