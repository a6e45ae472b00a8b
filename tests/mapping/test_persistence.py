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
        (
            lambda m: m["records"]["_models"]["items"][0].update(degrees={"value": True}),
            r"items\[0\].degrees must be an array",
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


def _item(meta):
    return meta["records"]["_models"]["items"][0]


def _array(name, value):
    return lambda meta, arrays: arrays.__setitem__(f"est/_models/0.{name}", value)


def _field(name, value):
    return lambda meta, arrays: _item(meta).__setitem__(name, {"value": value})


@pytest.mark.parametrize("kernel", ["dense", "sparse"])
@pytest.mark.parametrize(
    "tamper, match",
    [
        (_array("mean", np.ones(3)), "has shape"),
        (_array("degrees", np.full(40, np.nan)), "degrees must be finite"),
        (_array("sq_norms", np.ones((40, 1))), "sq_norms must be a numeric array of shape"),
        (_field("sigma", float("nan")), "sigma must be"),
        (_field("sigma", "abc"), "sigma must be"),
        (_field("alpha", 1.0), "alpha must be"),
        (_field("centre", 10**6), "centre must be"),
        (lambda m, a: a["est/_models/0.indices"].__iadd__(1000), "the training points of"),
        (lambda m, a: a.__setitem__("est/labels_", a["est/labels_"][:5]), "training points of"),
        (
            lambda m, a: a["est/centers_"].__setitem__(slice(None), a["est/centers_"][::-1]),
            "centers_",
        ),
        (lambda m, a: m["records"].clear(), "_models must be"),
    ],
)
def test_altered_fitted_state_is_refused_not_mispredicted(fitted, kernel, tamper, match):
    """Every field a query reads is checked on load: shapes that agree, finite values in
    range, and models that match the labels and centres. A file altered by hand or by another
    program must not load and then predict wrongly or fail deep in numpy."""
    est, X = fitted
    if kernel == "sparse":
        est = ManifoldClustering(n_clusters=2, min_cluster_size=5, kernel="sparse").fit(X)
    meta, arrays = persistence.dump(est, "est")
    meta, arrays = json.loads(json.dumps(meta)), {k: v.copy() for k, v in arrays.items()}
    tamper(meta, arrays)
    with pytest.raises(PersistenceError, match=match):
        persistence.load(ManifoldClustering, meta, arrays, "est")
