"""Synthetic sweeps and the diagnosis helpers (the full runs are in the docs)."""

import numpy as np
import pytest

from experiments.manifold.diagnosis import (
    embedding_leaf_merge,
    knn_leaf_merge,
    majority_merge_error,
    neighbour_distances,
    space_summary,
)
from experiments.manifold.sweeps import markdown_table, plot_sweeps, sweep_points
from mapping.manifold import branching_sequences
from scripts.manifold.methods import METHODS


def test_sweep_points_span_the_hard_regime():
    gap = sweep_points("gap")
    assert [p["gap"] / p["spacings"][-1] for p in gap] == pytest.approx([0.5, 1, 1.5, 2, 3, 6])
    density = sweep_points("density")
    assert all(p["gap"] == 0.1 for p in density)
    assert [p["spacings"][-1] / p["spacings"][0] for p in density] == pytest.approx([1, 2, 4, 6, 8])
    with pytest.raises(ValueError, match="sweep kind must be 'gap' or 'density'"):
        sweep_points("noise")


def test_sweep_table_and_figure(tmp_path):
    rows = [
        {"sweep": "gap", "ratio": r, "method": m, "train_error": e, "test_error": None}
        for r, e in ((0.5, 0.4), (1.0, 0.1))
        for m in METHODS
    ]
    table = markdown_table(rows, "ratio")
    assert "| 0.5 | 0.400 |" in table and "| 1.0 | 0.100 |" in table
    assert plot_sweeps(rows, tmp_path / "s.png").read_bytes()[:4] == b"\x89PNG"


def test_majority_merge_bound():
    y = np.array([0, 0, 0, 1, 1, 1])
    assert majority_merge_error(y, np.array([0, 0, 1, 2, 2, 3])) == 0.0  # pure leaves
    assert majority_merge_error(y, np.array([0, 0, 1, 1, 2, 2])) == pytest.approx(1 / 6)


def test_neighbour_distances_flag_a_crossing():
    # two parallel lines 1 apart sampled every 2: each point's nearest is on the other line
    X = np.array([[0, 0], [2, 0], [4, 0], [0, 1], [2, 1], [4, 1]], float)
    y = np.array([0, 0, 0, 1, 1, 1])
    d = neighbour_distances(X, y)
    np.testing.assert_allclose(d["within"], 2.0)
    np.testing.assert_allclose(d["between"], 1.0)
    assert space_summary(X, y)["nn_other_manifold"] == 1.0
    assert space_summary(X * [[1, 4]], y)["nn_other_manifold"] == 0.0


def test_branching_sequences_shape_and_checks():
    X, y = branching_sequences(5, 7, np.random.default_rng(0))
    assert X.shape == (40, 7) and np.array_equal(np.bincount(y), [5] * 8)
    with pytest.raises(ValueError, match="rng must be a numpy.random.Generator"):
        branching_sequences(5, 7, 0)


def test_knn_leaf_merge_joins_the_leaves_of_each_line():
    x = np.linspace(0, 1, 40)
    X = np.concatenate([np.column_stack([x, 0 * x]), np.column_stack([x, 0 * x + 5])])
    y = np.repeat([0, 1], 40)
    leaves = np.repeat([0, 1, 2, 3], 20)  # two leaves per line
    assert majority_merge_error(y, leaves) == 0.0
    groups = knn_leaf_merge(X, leaves, 2, k=5)
    assert np.array_equal(groups[:40], np.full(40, groups[0]))
    assert np.array_equal(groups[40:], np.full(40, groups[40])) and groups[0] != groups[40]


def test_embedding_leaf_merge_keeps_leaves_whole_and_joins_each_line():
    x = np.linspace(0, 1, 40)
    X = np.concatenate([np.column_stack([x, 0 * x]), np.column_stack([x, 0 * x + 0.3])])
    leaves = np.repeat([0, 1, 2, 3], 20)  # two leaves per line
    groups = embedding_leaf_merge(X, leaves, 2, k=5)
    assert len(set(groups[:40])) == 1 and len(set(groups[40:])) == 1
    assert groups[0] != groups[40]
    # a leaf that mixes both lines stays whole: the leaves are must-link groups
    mixed = leaves.copy()
    mixed[[0, 40]] = 4
    groups = embedding_leaf_merge(X, mixed, 2, k=5)
    assert groups[0] == groups[40]


@pytest.mark.parametrize("name", ["hallway", "lawn"])
def test_the_junction_centre_is_where_every_manifold_meets(worlds, name):
    from experiments.manifold.diagnosis import junction_centre

    c = junction_centre(worlds[name])
    angles = np.linspace(0, 2 * np.pi, 16, endpoint=False)
    around = c + 0.3 * np.stack([np.cos(angles), np.sin(angles)], axis=1)
    assert len(set(worlds[name].manifold_at(around).tolist())) == 4  # all four within 0.3 m


def test_errors_by_band_split_the_error_by_distance():
    from experiments.manifold.diagnosis import errors_by_band
    from mapping import clustering_error

    y = np.array([0, 0, 0, 0, 1, 1, 1, 1])
    pred = np.array([5, 5, 5, 7, 7, 7, 7, 5])  # two frames wrong, both near (distance < 2)
    distance = np.array([1.0, 6.0, 12.0, 0.5, 1.5, 6.0, 12.0, 0.2])
    rows = errors_by_band(y, pred, distance)
    assert [r["frames"] for r in rows] == [4, 0, 2, 2]
    assert [r["error"] for r in rows] == [0.5, None, 0.0, 0.0]
    assert rows[-1]["to_m"] is None
    total = sum(r["error"] * r["frames"] for r in rows if r["frames"]) / len(y)
    assert total == pytest.approx(clustering_error(y, pred))
