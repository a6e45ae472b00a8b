"""The ensemble combinations of the leaves (mapping.manifold.ensemble_combine)."""

import numpy as np
import pytest

from mapping.manifold import SYNTHETIC_SETS, ManifoldClustering
from mapping.manifold.ensemble_combine import (
    coassociation_groups,
    consensus_groups,
    ensemble_merge,
)
from mapping.metrics import clustering_error


def same_grouping(a, b):
    return clustering_error(np.asarray(a), np.asarray(b)) == 0.0


def test_coassociation_joins_the_leaves_most_partitions_join():
    # Six leaves, three cuts: leaves 0-2 and 3-5 are together in two of three partitions, the
    # third (one sigma's jump) swaps leaf 2 over; the accumulated evidence keeps 0-2 | 3-5.
    partitions = np.array([[0, 0, 0, 1, 1, 1], [0, 0, 1, 1, 1, 1], [1, 1, 1, 0, 0, 0]])
    assert same_grouping(coassociation_groups(partitions, 2), [0, 0, 0, 1, 1, 1])


def test_coassociation_gives_exactly_k_groups_even_with_ties():
    partitions = np.zeros((3, 5), dtype=np.intp)  # every leaf always together
    labels = coassociation_groups(partitions, 3)
    assert len(set(labels.tolist())) == 3


def test_consensus_picks_the_member_that_agrees_with_the_others():
    partitions = np.array([[0, 0, 1, 1], [0, 0, 1, 1], [0, 1, 1, 1]])
    chosen = consensus_groups(partitions, np.array([10, 10, 10, 10]))
    assert same_grouping(chosen, [0, 0, 1, 1])
    # the leaves' sizes weigh: one member alone is returned as it is
    assert same_grouping(consensus_groups(partitions[2:], np.ones(4)), [0, 1, 1, 1])


class _Scores:
    def __init__(self, M, sizes):
        self.M, self.sizes = M, sizes


def test_ensemble_merge_falls_back_when_no_sigma_is_usable_and_refuses_unknown_rules():
    # two adjacent leaves with no affinity at the only sigma: no usable cut
    M = np.zeros((1, 1, 3, 3))
    M[0, 0] = np.eye(3)
    scores = _Scores(M, np.full(3, 10.0))
    assert ensemble_merge(scores, 2, "coassociation", np.array([[0, 1]])) is None
    # as many leaves as clusters: every leaf its own group
    assert ensemble_merge(scores, 3, "consensus") == [[0], [1], [2]]
    with pytest.raises(ValueError, match="rule must be one of"):
        ensemble_merge(scores, 2, "vote")


@pytest.mark.parametrize("combine", ["coassociation", "consensus"])
def test_ensemble_rules_in_the_estimator(combine):
    X, y = SYNTHETIC_SETS["parallel_lines"]()
    model = ManifoldClustering(3, 20, combine=combine).fit(X)
    assert np.bincount(model.labels_).size == 3
    assert clustering_error(y, model.labels_) <= 0.05
    assert model.predict(X[:5]).shape == (5,)
