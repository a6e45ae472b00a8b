"""A robot's own data: bags imported with ``topomap import``, then both mapping methods, the
grouping evaluation and the report on a dataset without ground truth."""

import json

import numpy as np
import pytest

from scripts import report
from scripts.cli import main
from scripts.grouping.evaluate import evaluate_grouping
from sim.camera import CameraConfig
from sim.collect import CollectionSettings, collect_dataset
from sim.dataset import load_dataset
from sim.readers.rosbag import ImportSettings, import_rosbags
from tests.sim.readers.rosbag_fixtures import IMAGE, ODOM, SCAN, drive_from_sequence, write_bag

FRAMES = 12


@pytest.fixture(scope="module")
def imported(tmp_path_factory):
    """The hallway's three simulated drives, written as ROS 2 bags and imported (every scan)."""
    root = tmp_path_factory.mktemp("own")
    settings = CollectionSettings(
        worlds=("hallway",), frames=FRAMES, camera=CameraConfig(width=32, height=24)
    )
    collect_dataset(root / "sim", settings, jobs=1, progress=False)
    sim = load_dataset(root / "sim")
    bags = [
        write_bag(root / name, drive_from_sequence(seq, sim.max_range), encoding="png")
        for name, seq in sim.sequences.items()
    ]
    every = ImportSettings(SCAN, IMAGE, ODOM, world="corridor", min_travel=0.0)
    import_rosbags(bags, root / "data", every, progress=False)
    return sim, load_dataset(root / "data")


def test_group_eval_runs_without_ground_truth(imported, tmp_path, capsys):
    sim, data = imported
    assert main(["group-eval", "--data", str(data.path), "--out", str(tmp_path), "--quiet"]) == 0
    assert "no ground-truth labels" in capsys.readouterr().out
    result = json.loads((tmp_path / "grouping.json").read_text())
    assert result["ground_truth"] is False and result["loop"] == {}  # no loop outside our worlds
    rows = result["default"]["corridor"]
    assert set(rows) == {"frames", "sequences", "odometry", "odometry+icp"}  # no true poses
    for variant in ("odometry", "odometry+icp"):
        s = rows[variant]
        assert s["purity"] is None and s["max_drift_m"] is None and s["meets_targets"] is None
        assert 1 <= s["groups"] <= 3 * FRAMES
    assert result["targets_met"] == {}
    assert len(result["figures"]) == 4
    for name in result["figures"]:
        assert (tmp_path / name).read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    for row in result["compare"]["corridor"].values():
        assert row["purity"] is None and row["groups"] >= 1
    with np.load(tmp_path / "groups.npz", allow_pickle=False) as z:
        drives = z["default/corridor/groups"]
        groups = z["default/corridor/odometry+icp"]
        assert len(z["compare/corridor/manifold/images"]) == 3 * FRAMES
    assert drives.tolist() == [0] * FRAMES + [1] * FRAMES + [2] * FRAMES
    html = report.section_grouping(result)
    assert "No ground-truth labels" in html and "&ndash;" in html
    # the import changes nothing the grouping sees: the same groups as the simulated odometry
    evaluate_grouping(
        sim,
        tmp_path / "sim",
        true_poses=False,
        loop=False,
        compare=False,
        figures=False,
        progress=False,
    )
    with np.load(tmp_path / "sim" / "groups.npz", allow_pickle=False) as z:
        np.testing.assert_array_equal(groups, z["default/hallway/odometry+icp"])


def test_reproduce_clusters_without_ground_truth(imported, tmp_path, capsys, monkeypatch):
    import scripts.manifold.reproduce as rm

    one_set = dict(list(rm.make_all().items())[:1])  # the synthetic part is not under test
    monkeypatch.setattr(rm, "make_all", lambda: one_set)
    _, data = imported
    args = ["reproduce", "--data", str(data.path), "--out", str(tmp_path), "--clusters", "3"]
    assert main(args) == 0
    assert rm.NO_LABELS in capsys.readouterr().out
    result = json.loads((tmp_path / "results.json").read_text())
    assert result["ground_truth"] is False
    assert {r["method"] for r in result["real"]} == {"ours", "self-tuning"}  # no oracle
    for r in result["real"]:
        assert r["train_error"] is None and r["test_error"] is None
        assert r["K"] == 3 and r["Q"] == 3 * FRAMES // 2 // 3 and 1 <= r["clusters"] <= 3
    with np.load(tmp_path / "clusters.npz", allow_pickle=False) as z:
        assert len(z.files) == 2 * 2 * 3  # train and test, two methods, three feature sets
        assert all(len(z[k]) == 3 * FRAMES // 2 for k in z.files)
    for name in result["figures"]:
        assert (tmp_path / name).is_file()
    # the report's section renders the unscored results, with the note instead of numbers
    page = report.build_html("own data", [report.section_manifold(result)])
    assert page.count("No ground-truth labels") == 1 and "&ndash;" in page
