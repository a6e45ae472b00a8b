"""Clustering scores: known values, label-permutation invariance, input checks."""

import numpy as np
import pytest

from mapping.metrics import (
    adjusted_rand_index,
    best_matching,
    clustering_error,
    contingency_matrix,
    majority_merge_error,
    purity,
)


def test_contingency_matrix_counts_pairs_in_sorted_label_order():
    counts = contingency_matrix(["b", "a", "a", "b", "b"], [1, 0, 1, 1, 1])
    # rows: a, b; columns: 0, 1
    np.testing.assert_array_equal(counts, [[1, 1], [0, 3]])
    assert counts.dtype == np.int64  # counts, not floats (scikit-learn's dtype=None gives float64)


@pytest.mark.parametrize(
    ("y_true", "y_pred", "expected"),
    [
        ([0, 0, 1, 1], [1, 1, 0, 0], 0.0),
        ([0, 0, 0, 1, 1, 1], [0, 0, 1, 1, 1, 1], 1 / 6),
        # More predicted clusters than classes: the unmatched cluster's points are errors.
        ([0, 0, 0, 0], [0, 0, 1, 2], 0.5),
        # Fewer predicted clusters: one whole class cannot be matched.
        ([0, 0, 1, 1, 2, 2], [0, 0, 0, 0, 1, 1], 2 / 6),
        (["x"], ["y"], 0.0),
    ],
)
def test_clustering_error_known_cases(y_true, y_pred, expected):
    assert clustering_error(y_true, y_pred) == pytest.approx(expected)


def test_hungarian_beats_greedy_matching():
    # Class 0 -> cluster 0 (3 points) greedily leaves class 1 only cluster 1 (1 point): 4 correct.
    # The optimum pairs class 0 -> cluster 1 (2) and class 1 -> cluster 0 (3): 5 correct.
    y_true = [0, 0, 0, 0, 0, 1, 1, 1, 1]
    y_pred = [0, 0, 0, 1, 1, 0, 0, 0, 1]
    assert clustering_error(y_true, y_pred) == pytest.approx(1 - 5 / 9)


def test_scores_invariant_to_renaming_labels():
    rng = np.random.default_rng(0)
    y_true = rng.integers(0, 4, size=200)
    y_pred = np.where(rng.random(200) < 0.7, y_true, rng.integers(0, 5, size=200))
    renamed = np.array(["q", "r", "s", "t", "u"])[(y_pred + 2) % 5]
    assert clustering_error(y_true, renamed) == pytest.approx(clustering_error(y_true, y_pred))
    assert purity(y_true, renamed) == pytest.approx(purity(y_true, y_pred))
    assert adjusted_rand_index(y_true, renamed) == pytest.approx(
        adjusted_rand_index(y_true, y_pred)
    )
    assert 0.0 < clustering_error(y_true, y_pred) < 0.5


def test_purity_rewards_over_segmentation_unlike_clustering_error():
    y_true = [0, 0, 1, 1]
    singletons = [0, 1, 2, 3]
    assert purity(y_true, singletons) == 1.0
    assert clustering_error(y_true, singletons) == 0.5
    assert purity([0, 0, 1, 1], [0, 0, 0, 1]) == pytest.approx(0.75)


def test_ari_known_values():
    # the ARI of scikit-learn, behind this module's checks: identical partitions up to renaming
    # score 1, including the degenerate ones; a known hand-computed value
    assert adjusted_rand_index([0, 0, 1, 1], ["b", "b", "a", "a"]) == 1.0
    assert adjusted_rand_index([0, 0, 0], [1, 1, 1]) == 1.0
    assert adjusted_rand_index([0, 0, 1, 1], [0, 0, 1, 2]) == pytest.approx(0.5714285714)


@pytest.mark.parametrize("score", [clustering_error, purity, adjusted_rand_index])
def test_bad_input_raises(score):
    with pytest.raises(ValueError, match="same length"):
        score([0, 1, 1], [0, 1])
    with pytest.raises(ValueError) as err:
        score([], [])
    assert str(err.value) == "y_true and y_pred are empty; need at least one labelled point"
    with pytest.raises(ValueError, match="y_pred must be 1-D"):
        score([0, 1], [[0, 1]])


def test_best_matching_is_the_matching_clustering_error_scores():
    from mapping.metrics import best_matching

    y_true = np.array([0, 0, 0, 1, 1, 2])
    y_pred = np.array([7, 7, 5, 5, 5, 9])
    assert best_matching(y_true, y_pred) == {7: 0, 5: 1, 9: 2}
    # more clusters than classes: the extra cluster is left unmatched
    assert best_matching([0, 0, 1, 1], [3, 4, 5, 5]) in ({3: 0, 5: 1}, {4: 0, 5: 1})


@pytest.mark.parametrize(
    "score", [clustering_error, purity, adjusted_rand_index, contingency_matrix, best_matching]
)
def test_missing_or_infinite_labels_are_refused(score):
    """NaN labels (missing ground truth) were one class for every score but the ARI."""
    y = np.array([0, 1, 2, 3, 4, 4])
    nan = np.array([np.nan, np.nan, np.nan, np.nan, 1, 1])
    with pytest.raises(ValueError, match="y_true must hold a finite label for every point"):
        score(nan, y)
    with pytest.raises(ValueError, match="y_pred must hold a finite label .* got inf at index 2"):
        score(y, np.where(y == 2, np.inf, y))
    with pytest.raises(ValueError, match="y_true must hold a finite label .* got None at index 0"):
        score([None, None, 1], [0, 0, 1])
    with pytest.raises(ValueError, match="y_true must hold a finite label .* got nan at index 1"):
        score(np.array(["a", np.nan, "b"], dtype=object), [0, 0, 1])
    score(y.astype(float), y)  # finite float labels are labels


def test_majority_merge_error_gives_each_leaf_its_majority_label():
    assert majority_merge_error([0, 0, 1, 1, 2, 2], [3, 3, 1, 1, 0, 0]) == 0.0  # pure leaves
    # leaf 0 holds {0, 0, 1} -> 0, leaf 1 holds {1, 1, 2} -> 1: two points wrong of six
    assert majority_merge_error([0, 0, 1, 1, 1, 2], [0, 0, 0, 1, 1, 1]) == pytest.approx(2 / 6)
    # one leaf: everything takes the commonest label, string labels too
    assert majority_merge_error(["a", "b", "b", "c"], [7, 7, 7, 7]) == pytest.approx(2 / 4)
    # leaves merged into one cluster when they share a majority: the bound is not the
    # leaves' own error (3 leaves, 2 classes)
    y, leaves = [0, 0, 0, 1, 1, 1], [0, 0, 1, 1, 2, 2]
    assert majority_merge_error(y, leaves) == pytest.approx(1 / 6)
    assert clustering_error(y, leaves) == pytest.approx(2 / 6)
    with pytest.raises(ValueError, match="same length"):
        majority_merge_error([0, 1, 1], [0, 1])
