"""The paper reproductions of docs/guides/manifold-clustering.md, pinned: the synthetic table and
the 8-manifold image result, on the real default dataset (collected once per session)."""

import numpy as np
import pytest
from scipy.stats import binomtest

from mapping import ColorHistogramFeatures, ManifoldClustering, clustering_error
from scripts.manifold.reproduce import (
    PAPER_FEATURES,
    feature_sets,
    markdown_tables,
    paper_error,
    plot_labels,
    synthetic_rows,
)

# The dev seed (0, this dataset), on which the features and the merge rule were chosen, gives
# 13 test errors of 450 and 12 training errors of 450 (an older table in the docs says 2.2 %
# train). The margins are the 95 % Wilson upper bounds of those counts,
# the spread one run of this size has; the spectral combination gives the
# same counts. On 12 fresh seeds the default errs 2.9-21.8 % (mean 9.7 %; 13-31 % with the
# former separability merge; docs/guides/manifold-clustering.md):
# this pins the dev seed, not a claim about the method.
DEV_TEST_BOUND = binomtest(13, 450).proportion_ci(method="wilson").high  # 0.049
DEV_TRAIN_BOUND = binomtest(12, 450).proportion_ci(method="wilson").high  # 0.046


@pytest.fixture(scope="module")
def image_fit(default_dataset):
    y = default_dataset.concat("labels")
    train, test = default_dataset.paper_split()
    images = default_dataset.concat("images")
    features = ColorHistogramFeatures().fit(images[train])
    model = ManifoldClustering(8, 35).fit(features.transform(images[train]))
    return model, features, images, y, train, test


def test_image_errors_on_the_dev_seed_within_their_sampling_margin(image_fit):
    model, features, images, y, train, test = image_fit
    assert clustering_error(y[train], model.labels_) <= DEV_TRAIN_BOUND
    test_error = clustering_error(y[test], model.predict(features.transform(images[test])))
    assert test_error <= DEV_TEST_BOUND


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


def test_paper_numbers_only_beside_raw_pixels(default_dataset):
    names = list(feature_sets(default_dataset))
    assert PAPER_FEATURES in names
    for name in names:
        expected = {"ours": 0.0289, "best-sigma NCut": 0.344} if name == PAPER_FEATURES else {}
        for method in ("ours", "best-sigma NCut", "self-tuning"):
            assert paper_error(name, method) == expected.get(method), (name, method)
