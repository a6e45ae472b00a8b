"""ManifoldClustering on degenerate input: a one-value grid, more clusters than the tree's
leaves, copies of samples, constant features. Each is a clear error naming the argument or a
documented result with exactly K clusters."""

import warnings

import numpy as np
import pytest
from sklearn.utils._param_validation import InvalidParameterError

from mapping.manifold import ManifoldClustering
from mapping.manifold.tree import COMBINE_RULES


def two_lines(n=40):
    t = np.linspace(0.0, 1.0, n)
    return np.concatenate([np.c_[t, 0 * t], np.c_[t, 0 * t + 0.3]]), np.repeat([0, 1], n)


def fit(X, *args, **kwargs):
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        return ManifoldClustering(*args, **kwargs).fit(X)


@pytest.mark.parametrize("name", ["n_sigmas", "n_alphas"])
def test_a_grid_of_one_value_is_refused_by_name(name):
    X, _ = two_lines()
    with pytest.raises(InvalidParameterError, match=f"'{name}' parameter .* range \\[2, inf\\)"):
        ManifoldClustering(2, 10, **{name: 1}).fit(X)


@pytest.mark.parametrize("combine", COMBINE_RULES)
def test_the_smallest_grid_and_one_alpha_still_give_k_clusters(combine):
    X, _ = two_lines()
    for params in ({"n_sigmas": 2}, {"alpha_range": (0.9, 0.9)}):
        model = fit(X, 2, 10, combine=combine, **params)
        assert np.unique(model.labels_).size == 2


@pytest.mark.parametrize("combine", COMBINE_RULES)
def test_more_clusters_than_the_trees_leaves_splits_leaves_below_q(combine):
    """n = 80, Q = 16: the tree stops at 4 leaves; K = 5 splits the largest again (documented
    under min_cluster_size), never returns fewer than K clusters."""
    X, _ = two_lines()
    model = fit(X, 5, 16, combine=combine)
    assert np.unique(model.labels_).size == 5
    leaf_sizes = np.bincount(model.leaf_labels_)
    assert leaf_sizes.size >= 5 and leaf_sizes.min() >= 16 // 2


def test_more_clusters_than_samples_names_both_arguments():
    X, _ = two_lines()
    with pytest.raises(ValueError, match=r"n_clusters \* min_cluster_size = 81 \* 1"):
        ManifoldClustering(81, 1).fit(X)


@pytest.mark.parametrize("kernel", ["dense", "sparse"])
@pytest.mark.parametrize("combine", ["spectral", "coassociation", "consensus"])
def test_exactly_k_distinct_samples_give_one_cluster_each(kernel, combine):
    X, _ = two_lines()
    copies = np.repeat(X[[0, 20, 45]], 20, axis=0)
    model = fit(copies, 3, 5, kernel=kernel, combine=combine, n_components=8)
    for k in range(3):
        assert np.unique(model.labels_[copies[:, 0] == copies[20 * k, 0]]).size == 1
    assert np.unique(model.labels_).size == 3
    with pytest.raises(ValueError, match="n_clusters=4 needs at least 4 distinct samples"):
        fit(copies, 4, 5, kernel=kernel, combine=combine, n_components=8)


def test_every_sample_twice_gives_the_same_clusters():
    X, _ = two_lines()
    once = fit(X, 2, 10).labels_
    twice = fit(np.r_[X, X], 2, 10).labels_
    assert np.array_equal(twice[: len(X)], twice[len(X) :])
    assert np.array_equal(twice[: len(X)] == twice[0], once == once[0])


def test_constant_features_change_nothing_and_all_constant_is_refused():
    X, _ = two_lines()
    padded = np.c_[X, np.full(len(X), 5.0), np.zeros(len(X))]
    assert np.array_equal(fit(padded, 2, 10).labels_, fit(X, 2, 10).labels_)
    for K in (1, 2):
        with pytest.raises(ValueError, match="X: all samples are identical"):
            ManifoldClustering(K, 5).fit(np.full((40, 4), 3.0))
