"""The laser bound on two tiny lawn datasets (two seeds): every
representation gets the supervised bound and both label-free methods, per test seed."""

import json

import pytest

from experiments.manifold import laser_bound as lb
from sim.camera import CameraConfig
from sim.collect import CollectionSettings, collect_dataset


@pytest.fixture(scope="module")
def two_seeds(tmp_path_factory):
    paths = []
    for seed in (0, 1):
        path = tmp_path_factory.mktemp(f"lawn{seed}")
        settings = CollectionSettings(
            worlds=("lawn",), frames=16, seed=seed, camera=CameraConfig(width=32, height=24)
        )
        collect_dataset(path, settings, jobs=1, progress=False)
        paths.append(path)
    return paths


def test_bound_and_label_free_errors(two_seeds, tmp_path):
    dev, test = two_seeds
    result = lb.evaluate(dev, [test], n_clusters=4, min_size=3)
    methods = {r["method"] for r in result["rows"]}
    assert methods == {
        "5-NN (supervised)",
        "random forest (supervised)",
        "ours (label-free)",
        "scikit-learn kNN k=10 (label-free)",
    }
    assert {r["representation"] for r in result["rows"]} == set(lb.REPRESENTATIONS)
    for r in result["rows"]:
        assert len(r["errors"]) == 1 and 0.0 <= r["errors"][0] <= 1.0
        assert r["summary"]["mean"] == pytest.approx(r["errors"][0])
    # supervised on another drive of the same lawn: the scans tell the manifolds apart well
    knn = [r for r in result["rows"] if r["method"] == "5-NN (supervised)"]
    assert min(r["errors"][0] for r in knn) < 0.5
    text = lb.format_report(result)
    assert "| polar_grid | random forest (supervised) |" in text
    json.dumps(result)


def test_a_dataset_without_labels_is_refused(two_seeds, monkeypatch):
    from sim import dataset as ds

    monkeypatch.setattr(ds.Dataset, "has_ground_truth", property(lambda self: False))
    with pytest.raises(ValueError, match="needs the true manifold labels"):
        lb.evaluate(two_seeds[0], [two_seeds[1]], n_clusters=4, min_size=3)


def test_bound_only_skips_the_label_free_fits(two_seeds):
    dev, test = two_seeds
    result = lb.evaluate(dev, [test], representations=("sector_rings",), clustering=False)
    assert {r["method"] for r in result["rows"]} == {
        "5-NN (supervised)",
        "random forest (supervised)",
    }
    assert all(r["representation"] == "sector_rings" for r in result["rows"])


def test_scan_transformer_names():
    from mapping import ScanFeatures, ScanStatistics

    assert isinstance(lb.scan_transformer("sector_rings", 20.0), ScanStatistics)
    polar = lb.scan_transformer("polar_grid", 20.0)
    assert isinstance(polar, ScanFeatures) and polar.representation == "polar_grid"
    with pytest.raises(ValueError, match="representation must be one of"):
        lb.scan_transformer("sonar", 20.0)
