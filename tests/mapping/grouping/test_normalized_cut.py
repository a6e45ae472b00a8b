"""The recursion's edge cases of ``mapping.grouping.normalized_cut``: an eigenvector entry at its
mean, a bisection that splits nothing, and which blocks of a large graph are solved dense.

The eigensolver is replaced where a case needs an eigenvector that no small graph gives exactly
in floating point; the rest of the recursion runs as it is."""

import numpy as np
import pytest
import scipy.sparse as sp

from mapping.grouping import normalized_cut
from mapping.grouping.normalized_cut import (
    check_weights,
    recursive_ncut_partition,
    spectral_bisection,
)


def chain(n: int) -> np.ndarray:
    """A path graph of ``n`` nodes with unit weights (connected, so the eigensolver is asked)."""
    return np.diag(np.ones(n - 1), 1) + np.diag(np.ones(n - 1), -1)


def test_an_entry_at_the_mean_joins_the_side_at_or_above_it(monkeypatch):
    # Nodes with y >= mean(y) form A before the orientation that puts node 0 in A
    for y, expected in (
        ([1.0, 0.0, -1.0], [True, True, False]),  # node 1 at the mean joins node 0
        ([-1.0, 0.0, 1.0], [True, False, False]),  # node 1 joins node 2, the side above
    ):
        monkeypatch.setattr(normalized_cut, "_second_eigenvector", lambda *a, y=y: np.array(y))
        mask, _ = spectral_bisection(chain(3))
        np.testing.assert_array_equal(mask, expected)


def test_a_subgraph_that_splits_nothing_leaves_the_others_to_the_recursion(monkeypatch):
    # a triangle (node 0's) and a 4-clique joined by a weak edge; the triangle's eigenvector
    # is made constant, so the triangle cannot be split: it stays whole without an Ncut and the
    # 4-clique, still on the stack, is bisected all the same
    W = np.zeros((7, 7))
    W[:3, :3] = W[3:, 3:] = 1.0
    W[2, 3] = W[3, 2] = 0.1
    solve = normalized_cut._second_eigenvector

    def constant_for_the_triangle(sub, *args):
        return np.ones(3) if sub.shape[0] == 3 else solve(sub, *args)

    monkeypatch.setattr(normalized_cut, "_second_eigenvector", constant_for_the_triangle)
    labels, tree = recursive_ncut_partition(W)
    triangle, quad = tree.children
    np.testing.assert_array_equal(triangle.indices, [0, 1, 2])
    assert triangle.ncut is None and triangle.is_leaf
    assert quad.ncut is not None and quad.ncut >= 1.0  # proposed, rejected: a clique
    np.testing.assert_array_equal(labels, [0, 0, 0, 1, 1, 1, 1])


def test_blocks_up_to_dense_max_nodes_are_handed_on_dense(monkeypatch):
    # past DENSE_INDEX_MAX_NODES the graph is indexed sparse; a block of at most
    # DENSE_MAX_NODES nodes (the boundary included) is densified before its bisection
    monkeypatch.setattr(normalized_cut, "DENSE_INDEX_MAX_NODES", 5)
    monkeypatch.setattr(normalized_cut, "DENSE_MAX_NODES", 3)
    seen = []
    bisect = normalized_cut._bisect

    def spy(sub, *args):
        seen.append((sub.shape[0], sp.issparse(sub)))
        return bisect(sub, *args)

    monkeypatch.setattr(normalized_cut, "_bisect", spy)
    W = np.zeros((7, 7))
    W[:3, :3] = W[3:, 3:] = 1.0
    W[2, 3] = W[3, 2] = 0.1
    labels, _ = recursive_ncut_partition(sp.csr_array(W))
    np.testing.assert_array_equal(labels, [0, 0, 0, 1, 1, 1, 1])
    assert (3, False) in seen  # the boundary: dense
    assert all(sparse == (n > 3) for n, sparse in seen)
    assert (7, True) in seen and (4, True) in seen


def test_small_graphs_bisect_with_every_solver():
    # LOBPCG with a constraint needs 6 nodes; smaller graphs are solved dense whatever the
    # solver (a sparse solve of 4 or 5 nodes used to raise scipy's NotImplementedError)
    for n in range(2, 9):
        W = chain(n) * np.add.outer(np.arange(n), np.arange(n))  # uneven: no entry at the mean
        for laplacian in ("normalized", "unnormalized"):
            dense, _ = spectral_bisection(W, laplacian=laplacian, solver="dense")
            sparse, _ = spectral_bisection(W, laplacian=laplacian, solver="sparse")
            np.testing.assert_array_equal(sparse, dense)
            k = dense.sum()  # a path splits into a first and a last part
            assert 0 < k < n and dense[:k].all()
    dense, _ = recursive_ncut_partition(chain(5), threshold=2.0, solver="dense")
    sparse, _ = recursive_ncut_partition(chain(5), threshold=2.0, solver="sparse")
    np.testing.assert_array_equal(sparse, dense)
    assert dense.max() >= 1


def test_symmetry_is_checked_to_1e_9_of_the_largest_weight_or_of_1():
    # weights below 1: the tolerance is 1e-9 itself, and an asymmetry of exactly that passes
    at = np.array([[0.0, 0.0], [1e-9, 0.0]])
    np.testing.assert_array_equal(check_weights(at), at)
    for W in (1.5 * at, sp.csr_array(1.5 * at)):
        with pytest.raises(
            ValueError, match=r"^W must be symmetric \(max \|W - W.T\| = 1.5e-09\)$"
        ):
            check_weights(W)
    # weights of 1e6: relative to the largest, 1e-4 passes (1e-10 of it) and 1e-2 does not
    check_weights(np.array([[0.0, 1e6], [1e6 + 1e-4, 0.0]]))
    with pytest.raises(ValueError, match="must be symmetric"):
        check_weights(np.array([[0.0, 1e6], [1e6 + 1e-2, 0.0]]))
