"""The paper reproductions of docs/manifold-clustering.md, pinned: the synthetic table and the
8-manifold image result, on the real default dataset (collected once per session)."""

import json

import numpy as np
import pytest

from mapping import ColorHistogramFeatures, ManifoldClustering, clustering_error
from scripts.reproduce_manifold import markdown_tables, plot_labels, synthetic_rows

PAPER_TEST_ERROR = 0.0289  # Grudic & Mulligan, Section III-B


@pytest.fixture(scope="module")
def image_fit(default_dataset):
    y = default_dataset.concat("labels")
    train, test = default_dataset.paper_split()
    images = default_dataset.concat("images")
    features = ColorHistogramFeatures().fit(images[train])
    model = ManifoldClustering(8, 35).fit(features.transform(images[train]))
    return model, features, images, y, train, test


def test_image_test_error_meets_the_papers(image_fit):
    model, features, images, y, train, test = image_fit
    assert clustering_error(y[train], model.labels_) <= 0.03
    assert clustering_error(y[test], model.predict(features.transform(images[test]))) <= (
        PAPER_TEST_ERROR
    )


def test_image_clusters_are_the_eight_manifolds(image_fit):
    model, _, _, y, train, _ = image_fit
    # every cluster has a clear majority manifold, and the majorities are all different
    majority = [np.bincount(y[train][model.labels_ == k]).argmax() for k in range(8)]
    assert sorted(majority) == list(range(8))


def test_synthetic_table_per_cluster_sigma_at_least_as_good_as_ncut():
    rows, labels = synthetic_rows(progress=False)
    errors = {(r["set"], r["method"]): r["error"] for r in rows}
    for name in labels:
        assert errors[(name, "ours")] <= errors[(name, "best-sigma NCut")], name
    assert errors[("converging_paths", "best-sigma NCut")] > 0.2  # the paper's NCut failure


def test_label_plot_and_tables(tmp_path):
    y = np.repeat([0, 1, 2], 10)
    preds = {"ours": y.copy(), "best-sigma NCut": (y + 1) % 3, "self-tuning": np.zeros(30, int)}
    path = plot_labels({"toy": (y, preds)}, tmp_path / "labels.png", "index")
    assert path.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    result = {
        "synthetic": [{"set": "a", "method": "ours", "error": 0.0, "paper_claim": "x"}],
        "real": [
            {
                "features": "f",
                "method": "ours",
                "train_error": 0.01,
                "test_error": 0.02,
                "paper_error": 0.0289,
            }
        ],
    }
    text = markdown_tables(result)
    assert "| a | ours | 0.000 | x |" in text and "| f | ours | 1.0% | 2.0% | 2.9% |" in text
    json.dumps(result)
