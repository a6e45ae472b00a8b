"""The fast eq. 13 (Woodbury on the support of w, stacked clusters) against the dense formula.

The reference builds ``I - alpha S`` over the cluster's points plus the query and inverts it,
exactly as eq. 13 is printed; the fast path must agree to round-off on random data with
several clusters of different sizes, widths and alphas.
"""

import numpy as np
import pytest

from mapping.distances import TINY, squared_distances
from mapping.manifold.cluster_model import ClusterModel
from mapping.manifold.kernel import affinity, normalized_affinity
from mapping.manifold.signal_solvers import dense_signal, sparse_signal
from mapping.manifold.stacked_signal import Stack


def _reference(points, x, sigma, alpha, target):
    """``beta [(I - alpha S*)^-1]_{x, target}`` over the points plus x (eq. 13, dense)."""
    pts = np.vstack([points, x])
    S = normalized_affinity(squared_distances(pts), sigma)
    F = (1 - alpha) * np.linalg.inv(np.eye(len(pts)) - alpha * S)
    return F[-1, target]


def _clusters(rng, isolated=False):
    """Three random-walk clusters of different sizes, sigmas and alphas; with ``isolated`` the
    last gets a far training point of degree 0 (no H: the dense fallback)."""
    sizes, sigmas, alphas = (12, 20, 31), (0.012, 0.02, 0.5), (0.99, 0.9, 0.7)
    parts = [
        np.cumsum(rng.normal(scale=0.1, size=(m, 5)), axis=0) + 4.0 * j for j, m in enumerate(sizes)
    ]
    if isolated:
        parts[-1] = np.vstack([parts[-1], parts[-1][-1] + 50.0])
    X = np.vstack(parts)
    D2 = squared_distances(X)
    bounds = np.cumsum([0] + [len(p) for p in parts])
    models = []
    for j in range(3):
        idx = np.arange(bounds[j], bounds[j + 1])
        centre = int(rng.integers(len(idx)))
        block = D2[np.ix_(idx, idx)]
        models.append(
            ClusterModel.build(X, idx, block, sigmas[j], alphas[j], centre, np.dtype(np.float64))
        )
    # near training points of every cluster (partial or full support), and far from all
    queries = np.vstack([X[::3] + rng.normal(scale=0.05, size=X[::3].shape), np.full((1, 5), 1e3)])
    return X, models, queries


@pytest.mark.parametrize("isolated", [False, True])
def test_stacked_scores_match_dense_eq13(isolated):
    rng = np.random.default_rng(11)
    X, models, queries = _clusters(rng, isolated)
    assert (models[-1].inverse is None) == isolated
    scores, _ = Stack.of(models).scores(queries, normalize=False)
    expected = np.array(
        [[_reference(X[m.indices], q, m.sigma, m.alpha, m.centre) for m in models] for q in queries]
    )
    np.testing.assert_allclose(scores, expected, rtol=1e-9, atol=1e-300)
    # the data must exercise every case: empty, partial and full supports
    sizes = [np.count_nonzero(affinity(m.sq_distances(queries), m.sigma), axis=1) for m in models]
    counts = np.concatenate(sizes)
    assert (counts == 0).any() and (scores == 0).any()
    assert any(((s > 0) & (s < m.indices.size)).any() for s, m in zip(sizes, models, strict=True))
    assert any((s == m.indices.size).any() for s, m in zip(sizes, models, strict=True))
    # one cluster alone (ClusterModel.signal) agrees with the stacked batch, any target
    for j, m in enumerate(models):
        target = (m.centre + 5) % m.indices.size
        got = m.signal(m.sq_distances(queries), target)
        want = [_reference(X[m.indices], q, m.sigma, m.alpha, target) for q in queries]
        np.testing.assert_allclose(got, want, rtol=1e-9, atol=1e-300)
        np.testing.assert_allclose(scores[:, j], m.signal(m.sq_distances(queries), m.centre))


def test_sparse_solver_matches_dense_solver_on_random_affinities():
    # random affinities with random exact zeros: every support size from 0 to m
    rng = np.random.default_rng(12)
    m = 25
    X = np.cumsum(rng.normal(scale=0.1, size=(m, 3)), axis=0)
    model = ClusterModel.build(X, np.arange(m), squared_distances(X), 0.2, 0.99, 0, np.float64)
    w = rng.random((60, m)) * (rng.random((60, m)) < np.linspace(0, 1, 60)[:, None])
    w[:3] = 0.0
    w[3, 4] = 1e-310  # a single subnormal affinity: unreachable (total below _TINY), F = 0
    w[4] = 0.0
    w[4, 5] = TINY  # exactly TINY: unreachable too
    for target in (0, 7, m - 1):
        dense = dense_signal(model.weights, model.degrees, model.alpha, w, target)
        sparse = sparse_signal(
            model.inverse[None],
            model.degrees[None],
            w,
            np.zeros(60, dtype=np.intp),
            np.full(60, target),
            np.full(60, model.alpha),
        )
        np.testing.assert_allclose(sparse, dense, rtol=1e-10, atol=0)
        reachable = w.sum(axis=1) > 1e-300
        assert not reachable[:5].any() and reachable.sum() > 40
        np.testing.assert_array_equal(sparse > 0, reachable)


def _chain_cluster(m):
    """W and d of m points on a line (unit spacing, sigma 1), its diagonal 0 as the model's."""
    W = affinity(squared_distances(np.arange(float(m))[:, None]), 1.0)
    np.fill_diagonal(W, 0.0)
    return W, W.sum(axis=1)


def test_dense_signal_is_the_same_for_rows_solved_together_or_one_by_one():
    # 200 points: more query rows (150) than one batch of m x m systems holds (100)
    W, d = _chain_cluster(200)
    rng = np.random.default_rng(0)
    queries = rng.uniform(0, 199, size=(150, 1))
    w = affinity(squared_distances(queries, np.arange(200.0)[:, None]), 1.0)
    together = dense_signal(W, d, 0.9, w, 7)
    alone = np.concatenate([dense_signal(W, d, 0.9, w[i : i + 1], 7) for i in range(150)])
    np.testing.assert_allclose(together, alone, rtol=1e-12)
    assert np.all(together[np.abs(w.argmax(axis=1) - 7) < 20] > 0)


def test_a_row_whose_affinities_sum_to_tiny_has_signal_zero():
    # exactly TINY counts as underflowed, like the sparse solver's support (total > TINY)
    W, d = _chain_cluster(6)
    w = np.zeros((2, 6))
    w[0, 2] = TINY
    w[1, 2] = 2 * TINY
    out = dense_signal(W, d, 0.9, w, 2)
    assert out[0] == 0.0 and out[1] > 0.0
