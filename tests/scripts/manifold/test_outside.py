"""``topomap manifold-eval``: an outside clusterer through the protocol on tiny datasets,
with n_clusters passed, the held-out assignment named, and a failing seed recorded."""

import json
import sys

import pytest

from scripts.cli import main as cli_main
from scripts.leaderboard import OutsideMethod, read_result
from scripts.manifold import outside
from scripts.manifold import protocol as mp

FAILS_ONCE = '''
class FailsOnce:
    """Fails on its first fit, then clusters everything into one cluster."""
    calls = 0
    def __init__(self, n_clusters=2):
        self.n_clusters = n_clusters
    def fit(self, X):
        FailsOnce.calls += 1
        if FailsOnce.calls == 1:
            raise RuntimeError("no luck on this seed")
        self.labels_ = [0] * len(X)
        return self
'''


@pytest.fixture(scope="module")
def root(tmp_path_factory):
    from sim.camera import CameraConfig
    from sim.collect import CollectionSettings, collect_dataset

    root = tmp_path_factory.mktemp("manifold_eval")
    for seed in (1, 2, 3):
        settings = CollectionSettings(
            worlds=("lawn",), frames=16, seed=seed, camera=CameraConfig(32, 24)
        )
        collect_dataset(mp.dataset_dir(root, seed), settings, jobs=1, progress=False)
    return root


@pytest.fixture
def small_k(monkeypatch):
    monkeypatch.setattr(outside, "K", 3)  # 24 map frames cannot hold the paper's K = 8, Q = 35
    monkeypatch.setattr(outside, "Q", 3)


def test_a_clusterer_without_predict_is_scored_by_nearest_neighbour(root, small_k):
    method = OutsideMethod("sklearn.cluster:SpectralClustering", ("fit",), {"n_init": 2})
    result = outside.evaluate_method(
        root, method, ("interleaved", "held-out"), ("hsv",), (1, 2), progress=False
    )
    assert result["method"]["params"] == {
        "n_clusters": 3,
        "random_state": "the dataset seed",
        "n_init": 2,
    }
    assert result["method"]["protocol_params"] == ["n_clusters", "random_state"]
    assert result["protocol"] == {"name": mp.PROTOCOL[0], "version": mp.PROTOCOL[1]}
    assert result["split"] == "test"
    assert [(r["group"], r["unit"]) for r in result["records"]] == [
        ("interleaved/hsv", "seed 1"),
        ("interleaved/hsv", "seed 2"),
        ("held-out/hsv", "seed 1"),
        ("held-out/hsv", "seed 2"),
    ]
    for r in result["records"]:
        assert r["failure"] is None and 0.0 <= r["value"] <= 1.0
        assert r["assignment"] == outside.NEAREST and r["clusters"] <= 3
    assert "nearest training neighbour" in result["method"]["notes"]
    again = outside.evaluate_method(root, method, ("interleaved",), ("hsv",), (1,), progress=False)
    assert again["records"][0]["value"] == result["records"][0]["value"]  # same seed, same


def test_a_builtin_method_gets_the_protocols_own_number(root, small_k, monkeypatch):
    monkeypatch.setattr(mp, "K", 3)
    monkeypatch.setattr(mp, "Q", 3)
    result = outside.evaluate_method(root, "ours", ("interleaved",), ("hsv",), (1,), progress=False)
    (record,) = result["records"]
    (row,) = mp.cell(root, "interleaved", "hsv", 1, ("ours",))["rows"]
    assert record["value"] == row["test_error"] and record["assignment"] == "predict"
    assert result["method"]["name"] == "ours"


def test_a_failing_seed_is_recorded_and_the_run_goes_on(
    root, small_k, tmp_path, monkeypatch, capsys
):
    (tmp_path / "fails_once_mod.py").write_text(FAILS_ONCE)
    monkeypatch.chdir(tmp_path)
    monkeypatch.setattr(sys, "path", list(sys.path))
    out = tmp_path / "out"
    code = cli_main(
        [
            "manifold-eval",
            "--root",
            str(root),
            "--out",
            str(out),
            "--quiet",
            "--method",
            "fails_once_mod:FailsOnce",
            "--seeds",
            "1",
            "2",
            "--conditions",
            "interleaved",
        ]
    )
    assert code == 0
    (path,) = out.glob("*.json")
    first, second = read_result(path)["records"]
    assert first["failure"] == "RuntimeError: no luck on this seed" and first["value"] is None
    assert second["failure"] is None and second["value"] > 0  # one cluster: errors
    printed = capsys.readouterr().out
    assert "failed interleaved/hsv seed 1: RuntimeError" in printed
    assert "| FailsOnce | 1 | 1 |" in printed  # one seed scored, one failed


@pytest.mark.parametrize(
    ("argv", "match"),
    [
        (["--method", "no_such_mod_q:X"], "does not import"),
        (["--method", "collections:OrderedDict"], "has no fit method"),
        ([], "give --method"),
        (["--method", "sklearn.cluster:KMeans", "--seeds", "0", "1"], "dev seed"),
    ],
)
def test_bad_input_is_one_clear_line(root, tmp_path, capsys, argv, match):
    code = cli_main(["manifold-eval", "--root", str(root), "--out", str(tmp_path), *argv])
    assert code == 2
    assert match in capsys.readouterr().err


def test_a_missing_dataset_is_named(tmp_path):
    method = OutsideMethod("sklearn.cluster:KMeans", ("fit",))
    with pytest.raises(ValueError, match="m-data-4.*not collected"):
        outside.evaluate_method(tmp_path, method, ("interleaved",), ("hsv",), (4,), progress=False)
    assert json.dumps(outside.file_name(method.describe(n_clusters=8))).endswith('.json"')
