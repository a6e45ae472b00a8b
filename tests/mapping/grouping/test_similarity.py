"""kNN Gaussian similarity graphs (the image graph of the observation-grouping evaluation)."""

import numpy as np
import pytest

from mapping.grouping.normalized_cut import recursive_ncut_partition
from mapping.grouping.similarity import default_n_neighbors, knn_gaussian_affinity


def test_graph_is_symmetric_sparse_with_unit_diagonal():
    X = np.random.default_rng(0).normal(size=(50, 7))
    W, sigma = knn_gaussian_affinity(X, n_neighbors=4)
    Wd = W.toarray()
    np.testing.assert_allclose(Wd, Wd.T)
    np.testing.assert_array_equal(np.diag(Wd), 1.0)
    off = (Wd > 0).sum(axis=1) - 1
    assert off.min() >= 4 and off.max() < 49  # own neighbours at least, never everything
    # sigma is the median 4th-neighbour distance
    D = np.linalg.norm(X[:, None] - X[None], axis=2)
    np.fill_diagonal(D, np.inf)
    assert sigma == pytest.approx(np.median(np.sort(D, axis=1)[:, 3]))
    i, j = np.argwhere(np.triu(Wd, 1) > 0)[0]
    assert Wd[i, j] == pytest.approx(np.exp(-(D[i, j] ** 2) / (2 * sigma**2)))


def test_two_separated_blobs_are_two_groups():
    rng = np.random.default_rng(1)
    X = np.concatenate([rng.normal(0, 0.1, (30, 3)), rng.normal(5, 0.1, (30, 3))])
    W, _ = knn_gaussian_affinity(X, n_neighbors=29)
    labels, _ = recursive_ncut_partition(W)
    np.testing.assert_array_equal(labels, np.repeat([0, 1], 30))


def test_default_neighbours_and_bad_input():
    assert default_n_neighbors(100) == 10 and default_n_neighbors(2) == 1
    W, sigma = knn_gaussian_affinity(np.zeros((4, 2)), n_neighbors=3)
    assert sigma == 0 and W.toarray().min() == 1.0  # identical vectors: all edges full
    for X, match in ((np.zeros((1, 3)), "1 sample"), ([[0.0, np.nan], [1, 1]], "NaN")):
        with pytest.raises(ValueError, match=match):
            knn_gaussian_affinity(X)
    with pytest.raises(ValueError, match="n_neighbors"):
        knn_gaussian_affinity(np.zeros((5, 2)), n_neighbors=5)
