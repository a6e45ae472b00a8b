"""Estimators saved without pickle and loaded from untrusted descriptions."""

import json

import numpy as np
import pytest

from mapping import persistence
from mapping.features import ImageFeatures
from mapping.manifold import ManifoldClustering
from mapping.persistence import PersistenceError


@pytest.fixture(scope="module")
def fitted():
    rng = np.random.default_rng(0)
    t = np.linspace(0, 1, 40)
    X = np.concatenate([np.c_[t, 0 * t], np.c_[t, 0 * t + 0.5]]) + rng.normal(0, 1e-3, (80, 2))
    return ManifoldClustering(n_clusters=2, min_cluster_size=5).fit(X), X


def _round_trip(est, prefix="est"):
    meta, arrays = persistence.dump(est, prefix)
    meta = json.loads(json.dumps(meta))  # what a file gives back
    return persistence.load(type(est), meta, arrays, prefix), meta, arrays


def test_round_trip_predicts_identically(fitted):
    est, X = fitted
    loaded, meta, _ = _round_trip(est)
    np.testing.assert_array_equal(loaded.predict(X), est.predict(X))
    np.testing.assert_array_equal(loaded.signal(X, 1), est.signal(X, 1))
    assert meta["records"]["_models"]["class"] == "ClusterModel"
    assert "tree_" in meta["skipped"]


def test_object_arrays_are_skipped_not_pickled(fitted):
    est, _ = fitted
    est.feature_names_in_ = np.array(["a", "b"], dtype=object)  # as after a DataFrame fit
    try:
        meta, arrays = persistence.dump(est, "est")
    finally:
        del est.feature_names_in_
    assert "feature_names_in_" in meta["skipped"]
    assert all(a.dtype != object for a in arrays.values())


def test_only_known_classes_are_saved_or_loaded(fitted):
    est, _ = fitted
    with pytest.raises(TypeError, match="cannot save a list"):
        persistence.dump([], "x")
    meta, arrays = persistence.dump(est, "est")
    with pytest.raises(PersistenceError, match="is a 'ManifoldClustering', not a ImageFeatures"):
        persistence.load(ImageFeatures, meta, arrays, "est")
    with pytest.raises(PersistenceError, match="cannot be loaded"):
        persistence.load(dict, meta, arrays, "est")


def test_a_file_from_before_the_kernel_parameters_loads_with_their_defaults(fitted):
    est, X = fitted
    meta, arrays = persistence.dump(est.set_params(n_neighbors=7), "est")
    meta = json.loads(json.dumps(meta))
    for name in ("kernel", "n_neighbors", "n_components"):
        meta["params"].pop(name)
    loaded = persistence.load(ManifoldClustering, meta, arrays, "est")
    assert loaded.n_neighbors == ManifoldClustering().n_neighbors != 7
    np.testing.assert_array_equal(loaded.predict(X), est.predict(X))
    est.set_params(n_neighbors=10)


@pytest.mark.parametrize(
    ("change", "match"),
    [
        (lambda m: m["params"].update(n_clusters="two"), "params are not valid"),
        (lambda m: m["params"].pop("n_clusters"), "params must have exactly"),
        (lambda m: m["fitted"].update(Labels_={"value": 1}), "not a fitted attribute"),
        (lambda m: m["records"].update(__dict__={}), "not a private attribute"),
        (lambda m: m["records"].update(_validate_params={}), "not a private attribute"),
        (lambda m: m["records"]["_models"]["items"][0].pop("sigma"), "exactly the fields"),
        (
            lambda m: m["records"]["_models"]["items"][0].update(sigma={"value": [1]}),
            "JSON scalar",
        ),
    ],
)
def test_crafted_descriptions_are_refused(fitted, change, match):
    est, _ = fitted
    meta, arrays = persistence.dump(est, "est")
    meta = json.loads(json.dumps(meta))
    change(meta)
    with pytest.raises(PersistenceError, match=match):
        persistence.load(ManifoldClustering, meta, arrays, "est")


def test_arrays_must_be_numeric_and_under_the_prefix(fitted):
    est, _ = fitted
    meta, arrays = persistence.dump(est, "est")
    meta["fitted"]["labels_"] = {"array": "other/labels_"}
    with pytest.raises(PersistenceError, match="does not hold"):
        persistence.load(
            ManifoldClustering, meta, {**arrays, "other/labels_": arrays["est/labels_"]}, "est"
        )
    meta["fitted"]["labels_"] = {"array": "est/labels_"}
    strings = {**arrays, "est/labels_": np.array(["x"])}
    with pytest.raises(PersistenceError, match="not numeric"):
        persistence.load(ManifoldClustering, meta, strings, "est")
