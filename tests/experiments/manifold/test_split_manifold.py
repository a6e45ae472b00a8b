"""The K-group oracle of the leaves and the groupings the combination studies compare."""

import itertools

import numpy as np
import pytest

from experiments.manifold.combination_attempts import average_linkage
from experiments.manifold.split_manifold import k_group_oracle
from mapping import clustering_error


def _brute_force(y, leaves, k):
    """The smallest error over every grouping of the leaves into exactly k non-empty groups."""
    n_leaves = int(leaves.max()) + 1
    best = 1.0
    for grouping in itertools.product(range(k), repeat=n_leaves):
        if len(set(grouping)) == k:
            best = min(best, clustering_error(y, np.array(grouping)[leaves]))
    return best


@pytest.mark.parametrize("seed", range(6))
def test_the_oracle_is_the_best_grouping_into_exactly_k_groups(seed):
    rng = np.random.default_rng(seed)
    k, n_leaves = 3, 5
    leaves = rng.integers(0, n_leaves, 60)
    leaves[:n_leaves] = np.arange(n_leaves)  # every leaf non-empty
    y = rng.integers(0, k, 60)
    y[:k] = np.arange(k)
    assert k_group_oracle(y, leaves, k) == pytest.approx(_brute_force(y, leaves, k))


def test_the_oracle_must_spend_every_group_even_where_the_majority_would_not():
    # two pure leaves of label 0 and one mixed leaf: the majority grouping uses one group, the
    # oracle must give the mixed leaf's minority label a group of its own
    y = np.array([0] * 10 + [0] * 10 + [0] * 6 + [1] * 4)
    leaves = np.array([0] * 10 + [1] * 10 + [2] * 10)
    assert k_group_oracle(y, leaves, 2) == pytest.approx(6 / 30)


def test_average_linkage_joins_the_leaves_of_largest_mean_affinity():
    # 11 leaves to K = 8 groups: three joins, which must make {0, 1, 2} and {3, 4}
    from experiments.manifold import combination_attempts as study

    sizes = np.full(11, 10.0)
    mean = np.full((11, 11), 0.01)
    mean[:3, :3] = 0.9
    mean[3:5, 3:5] = 0.8
    np.fill_diagonal(mean, 1.0)
    labels = average_linkage(mean * np.outer(sizes, sizes), sizes)
    assert len(set(labels.tolist())) == study.K
    assert labels[0] == labels[1] == labels[2] and labels[3] == labels[4]
    assert len({labels[0], labels[3], *labels[5:].tolist()}) == study.K
