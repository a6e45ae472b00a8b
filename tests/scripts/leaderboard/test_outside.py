"""Loading a method named ``package.module:Class``: bad names, modules that do not import and
classes without the interface are refused with the reason; parameters are parsed as
literals."""

import sys

import pytest

from scripts.leaderboard import OutsideMethod, load_method, parse_params


def test_params_are_literals_or_text():
    assert parse_params(["k=3", "a=0.5", "x=None", "name=rbf", "t=(1, 2)", "s='q'"]) == {
        "k": 3,
        "a": 0.5,
        "x": None,
        "name": "rbf",
        "t": (1, 2),
        "s": "q",
    }
    for bad, match in (("k", "KEY=VALUE"), ("1k=2", "KEY=VALUE"), ("a=1e999", "finite")):
        if match:
            with pytest.raises(ValueError, match=match):
                parse_params([bad])
    with pytest.raises(ValueError, match="twice"):
        parse_params(["k=1", "k=2"])


@pytest.mark.parametrize(
    ("spec", "match"),
    [
        ("sklearn.cluster.KMeans", "must be package.module:Class"),
        ("no_such_module_xyz:C", "does not import .ModuleNotFoundError"),
        ("sklearn.cluster:NoSuchClass", "has no 'NoSuchClass'"),
        ("sklearn.cluster:k_means", "not a class"),
        ("sklearn.preprocessing:StandardScaler", None),
        ("collections:OrderedDict", "has no fit method"),
    ],
)
def test_a_bad_method_is_refused_with_the_reason(spec, match):
    if match is None:
        assert load_method(spec, ("fit",)).__name__ == "StandardScaler"
    else:
        with pytest.raises(ValueError, match=match):
            load_method(spec, ("fit",))


def test_a_module_that_raises_on_import_is_reported(tmp_path, monkeypatch):
    (tmp_path / "broken_method_mod.py").write_text("raise RuntimeError('boom at import')\n")
    monkeypatch.chdir(tmp_path)  # loaded like python -m: the current directory is searched
    monkeypatch.setattr(sys, "path", list(sys.path))
    with pytest.raises(ValueError, match="RuntimeError: boom at import"):
        load_method("broken_method_mod:C")


def test_n_clusters_is_passed_only_where_taken_and_never_over_the_users():
    spectral = OutsideMethod("sklearn.cluster:SpectralClustering", ("fit",))
    assert spectral.make(n_clusters=8).n_clusters == 8
    assert (
        OutsideMethod("sklearn.cluster:SpectralClustering", ("fit",), {"n_clusters": 3})
        .make(n_clusters=8)
        .n_clusters
        == 3
    )
    hdbscan = OutsideMethod("sklearn.cluster:HDBSCAN", ("fit",))
    assert hdbscan.describe(n_clusters=8)["params"] == {}
    assert spectral.describe(n_clusters=8)["protocol_params"] == ["n_clusters"]
    assert hdbscan.make(n_clusters=8).min_cluster_size == 5
    with pytest.raises(ValueError, match="takes no parameter 'n_neighbours'"):
        OutsideMethod("sklearn.cluster:HDBSCAN", ("fit",), {"n_neighbours": 3})
