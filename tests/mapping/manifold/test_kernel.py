"""The functional cores of ManifoldClustering against closed forms (eq. 1-13 of the paper)."""

import numpy as np
import pytest

from mapping.distances import squared_distances
from mapping.manifold import stacked_signal as _manifold_stack
from mapping.manifold.cluster_model import ClusterModel
from mapping.manifold.kernel import (
    SpectralBasis,
    alpha_from_t,
    manifold_distances,
    manifold_kernel,
    normalized_affinity,
    outlier_vector,
    seed_pair,
)
from mapping.manifold.split import SearchSpace, split_scores
from mapping.manifold.stacked_signal import Stack


@pytest.fixture
def cloud():
    rng = np.random.default_rng(3)
    X = np.concatenate([rng.normal(size=(25, 4)), rng.normal(size=(20, 4)) + 3.0])
    return X, squared_distances(X)


@pytest.mark.parametrize("alpha", [0.5, 0.9, 0.999])
def test_eigen_path_matches_closed_form(cloud, alpha):
    _, D2 = cloud
    sigma = 1.3
    basis = SpectralBasis.from_sq_distances(D2, sigma)
    U = manifold_kernel(normalized_affinity(D2, sigma), alpha)  # np.linalg.inv
    np.testing.assert_allclose(basis.dense_kernel(alpha), U, rtol=1e-9, atol=1e-12)
    g = basis.gains(np.array([alpha]))
    np.testing.assert_allclose(
        basis.column_norms(g)[:, 0], np.linalg.norm(U, axis=0) / (1 - alpha), rtol=1e-9
    )
    cols = np.array([7])
    np.testing.assert_allclose(
        basis.kernel_columns(g, cols)[:, 0], U[:, 7] / (1 - alpha), rtol=1e-9
    )
    np.testing.assert_allclose(
        basis.gram_columns(g, cols)[:, 0], (U.T @ U)[:, 7] / (1 - alpha) ** 2, rtol=1e-8
    )


def test_manifold_distances_are_a_bounded_symmetric_dissimilarity(cloud):
    _, D2 = cloud
    D_M = manifold_distances(manifold_kernel(normalized_affinity(D2, 0.8), 0.95))
    np.testing.assert_array_equal(D_M, D_M.T)
    np.testing.assert_array_equal(np.diag(D_M), 0.0)
    assert D_M.min() >= 0.0 and D_M.max() <= 1.0
    # The two blobs are far apart along the manifold, points within a blob close.
    assert D_M[:25, 25:].mean() > 3 * D_M[:25, :25].mean()


def test_isolated_point_gets_zero_row_not_nan():
    X = np.array([[0.0], [0.1], [0.2], [50.0]])
    S = normalized_affinity(squared_distances(X), 0.1)
    assert np.isfinite(S).all()
    np.testing.assert_array_equal(S[3], 0.0)


def test_printed_eq12_selects_the_first_seed_and_the_corrected_rule_does_not(cloud):
    _, D2 = cloud
    D_M = SpectralBasis.from_sq_distances(D2, 1.0).dense_distances(0.99)
    O_d = outlier_vector(D_M)
    l1, l2 = seed_pair(D_M)
    assert l1 == int(np.argmin(O_d))
    # As printed: argmin O_d * D_M[:, l1] is l1 itself (D_M[l1, l1] = 0).
    assert int(np.argmin(O_d * D_M[:, l1])) == l1
    assert l2 != l1
    # The corrected second seed lies in the other blob.
    assert (l1 < 25) != (l2 < 25)


@pytest.mark.parametrize("sign", ["corrected", "printed"])
def test_fast_omega_equals_omega_from_dense_matrices(cloud, sign):
    _, D2 = cloud
    alpha, sigma = 0.97, 1.1
    basis = SpectralBasis.from_sq_distances(D2, sigma)
    omega, in_first, seeds = split_scores(basis, np.array([alpha]), 5, SearchSpace(omega_sign=sign))
    U = basis.dense_kernel(alpha)
    V = U / np.linalg.norm(U, axis=0)
    D_M = manifold_distances(U)
    l1, l2 = seed_pair(D_M)
    assert (l1, l2) == tuple(seeds[:, 0])
    p1 = V[:, l1] > V[:, l2]  # eq. 8
    np.testing.assert_array_equal(in_first[:, 0], p1)
    d11 = D_M[np.ix_(p1, p1)].mean()
    d12 = D_M[np.ix_(p1, ~p1)].mean()
    spread = d12 - d11 if sign == "corrected" else d11 - d12
    expected = min(p1.sum(), (~p1).sum()) / p1.size * spread  # eq. 9
    np.testing.assert_allclose(omega[0], expected, rtol=1e-8, atol=1e-12)


def test_split_respects_min_size_by_moving_lowest_margin_points(cloud):
    _, D2 = cloud
    basis = SpectralBasis.from_sq_distances(D2, 1.0)
    _, in_first, _ = split_scores(basis, np.array([0.6, 0.99]), 22, SearchSpace())
    sizes = in_first.sum(axis=0)
    assert (sizes >= 22).all() and (sizes <= 45 - 22).all()


def test_split_breaks_round_off_ties_by_index_so_last_bits_do_not_move_it():
    # Three evenly spaced segments, each symmetric about its middle: the two middle points of a
    # segment have equal O_d in exact arithmetic, so eq. 10's argmin is a tie that round-off
    # used to decide (seeds 19, 20, 99 or 100 over these draws; docs: "Ties broken by index").
    t = np.linspace(0.0, 1.0, 40)
    segment = np.c_[t, 0.3 * t]
    X = np.concatenate([segment, segment + [0.0, 0.5], segment + [3.0, 0.0]])
    alphas = np.array([0.9, 0.99, 0.999])
    results = []
    for draw in range(6):
        noise = np.random.default_rng(draw).standard_normal(X.shape)
        Xd = X if draw == 0 else X * (1.0 + 1e-12 * noise)
        basis = SpectralBasis.from_sq_distances(squared_distances(Xd), 0.02)
        results.append(split_scores(basis, alphas, 20, SearchSpace()))
    for omega, in_first, seeds in results:
        assert seeds[0].tolist() == [19, 19, 19]  # the lower of the tied middle pair
        np.testing.assert_array_equal(seeds, results[0][2])
        np.testing.assert_array_equal(in_first, results[0][1])
        np.testing.assert_allclose(omega, results[0][0], rtol=1e-9)


def _closed_form_signal(X_train, x, sigma, alpha, target):
    pts = np.vstack([X_train, x])
    S = normalized_affinity(squared_distances(pts), sigma)
    F = (1 - alpha) * np.linalg.inv(np.eye(len(pts)) - alpha * S)
    return F[-1, target]


@pytest.mark.parametrize("dtype", [np.float64, np.float32])
def test_eq13_signal_matches_closed_form(dtype):
    rng = np.random.default_rng(0)
    X = np.cumsum(rng.normal(scale=0.1, size=(30, 6)), axis=0) + 100.0  # offset: tests centring
    queries = X[:5] + rng.normal(scale=0.05, size=(5, 6))
    sigma, alpha, target = 0.15, 0.99, 11
    idx = np.arange(30)
    model = ClusterModel.build(X, idx, squared_distances(X), sigma, alpha, 4, np.dtype(dtype))
    got = model.signal(model.sq_distances(queries), target)
    expected = [_closed_form_signal(X, q, sigma, alpha, target) for q in queries]
    rtol = 1e-9 if dtype == np.float64 else 1e-4
    np.testing.assert_allclose(got, expected, rtol=rtol)
    assert (got > 0).all()


def test_eq13_signal_is_zero_when_the_point_is_unreachable():
    X = np.linspace(0, 1, 20)[:, None]
    model = ClusterModel.build(X, np.arange(20), squared_distances(X), 0.05, 0.99, 0, np.float64)
    far = model.signal(model.sq_distances(np.array([[1e4]])), 0)
    np.testing.assert_array_equal(far, 0.0)


# --- the projected distances of eq. 13 (one r x d product per query) ----------------------------
def _curve_in_subspace(rng, n=40, rank=5, d=300, noise=0.0):
    """Points of a smooth curve spanning ``rank`` directions of R^d, offset far from 0."""
    t = np.linspace(0, 3, n)[:, None]
    coeffs = np.hstack([np.sin(t * (k + 1)) for k in range(rank)])
    X = coeffs @ rng.normal(size=(rank, d)) + 50.0
    return X + noise * rng.normal(size=X.shape)


def test_projection_basis_spans_the_cluster_and_distances_are_exact():
    rng = np.random.default_rng(3)
    X = _curve_in_subspace(rng)
    queries = X[:7] + 0.01 * rng.normal(size=(7, X.shape[1]))  # mostly outside the span
    model = ClusterModel.build(X, np.arange(40), squared_distances(X), 0.5, 0.99, 0, np.float64)
    # a centred curve of 5 directions spans at most 5; nothing of the queries is lost
    assert model.basis.shape[0] <= 5
    np.testing.assert_allclose(model.basis @ model.basis.T, np.eye(model.basis.shape[0]), atol=1e-9)
    exact = ((queries[:, None, :] - X[None, :, :]) ** 2).sum(axis=2)
    np.testing.assert_allclose(model.sq_distances(queries), exact, rtol=1e-9, atol=1e-9)


def test_projection_tol_drops_noise_directions_within_the_stated_bound():
    rng = np.random.default_rng(4)
    X = _curve_in_subspace(rng, noise=1e-3)
    queries = X[:7] + 1e-3 * rng.normal(size=(7, X.shape[1]))
    block = squared_distances(X)
    full = ClusterModel.build(X, np.arange(40), block, 0.5, 0.99, 0, np.float64)
    cut = ClusterModel.build(X, np.arange(40), block, 0.5, 0.99, 0, np.float64, tol=1e-4)
    assert full.basis.shape[0] == 39 and cut.basis.shape[0] < 10  # noise spans the rest
    # the only term left out is -2 x_perp . r_i, at most 2 |x_perp| |r_i| (Cauchy-Schwarz)
    centred_q = queries - cut.mean
    x_perp = centred_q - (centred_q @ cut.basis.T) @ cut.basis
    r = (X - cut.mean) - cut.coords @ cut.basis
    bound = 2.0 * np.linalg.norm(x_perp, axis=1)[:, None] * np.linalg.norm(r, axis=1)[None, :]
    error = np.abs(cut.sq_distances(queries) - full.sq_distances(queries))
    assert (error <= bound + 1e-9).all() and error.max() > 0
    f_full = full.signal(full.sq_distances(queries), 3)
    np.testing.assert_allclose(cut.signal(cut.sq_distances(queries), 3), f_full, rtol=1e-3)


@pytest.mark.parametrize("dtype", [np.float64, np.float32])
def test_distances_of_all_clusters_match_each_cluster_alone(dtype, monkeypatch):
    # blocks of 2 rows: the batch takes the path that centres each block once for all clusters
    monkeypatch.setattr(_manifold_stack, "CENTRE_ELEMENTS", 600)
    rng = np.random.default_rng(5)
    X = np.vstack([_curve_in_subspace(rng, noise=1e-3), _curve_in_subspace(rng, noise=1e-3) + 3])
    D2 = squared_distances(X)
    parts = [np.arange(40), np.arange(40, 80)]
    models = [
        ClusterModel.build(X, idx, D2[np.ix_(idx, idx)], 0.5, 0.99, 0, np.dtype(dtype))
        for idx in parts
    ]
    queries = X[::9] + 1e-3 * rng.normal(size=(9, X.shape[1]))
    rtol = 1e-9 if dtype == np.float64 else 1e-3
    stack = Stack.of(models)
    d2 = stack.sq_distances(queries)
    for j, model in enumerate(models):
        both = d2[j, :, : stack.sizes[j]]
        np.testing.assert_allclose(both, model.sq_distances(queries), rtol=rtol, atol=rtol)


def test_spectral_basis_falls_back_when_divide_and_conquer_fails(monkeypatch):
    """LAPACK's divide-and-conquer eigensolver can fail to converge (seen on inverse-range scan
    features); the basis is then computed by the relatively robust driver instead."""
    import scipy.linalg

    from mapping.manifold import kernel as mk

    rng = np.random.default_rng(0)
    x = rng.normal(size=(30, 3))
    d = ((x[:, None] - x[None]) ** 2).sum(-1)
    expected = mk.SpectralBasis.from_sq_distances(d, 1.0)

    def failing(a, driver=None, **kw):
        if driver == "evd":
            raise scipy.linalg.LinAlgError("did not converge")
        return scipy.linalg.eigh(a, driver=driver, **kw)

    monkeypatch.setattr(mk, "eigh", failing)
    got = mk.SpectralBasis.from_sq_distances(d, 1.0)
    np.testing.assert_allclose(got.values, expected.values, atol=1e-10)
    # eigenvectors up to sign: the projector onto the top one is the same
    np.testing.assert_allclose(
        np.abs(got.vectors[:, -1]), np.abs(expected.vectors[:, -1]), atol=1e-8
    )


def test_manifold_kernel_takes_a_given_beta():
    S = normalized_affinity(squared_distances(np.arange(5.0)[:, None]), 1.0)
    inverse = np.linalg.inv(np.eye(5) - 0.9 * S)
    np.testing.assert_allclose(manifold_kernel(S, 0.9, beta=1.0), inverse, rtol=1e-12)
    np.testing.assert_allclose(manifold_kernel(S, 0.9), 0.1 * inverse, rtol=1e-12)


def test_parallel_columns_are_at_distance_zero_not_below():
    # u and 3u point the same way: 1 - cos rounds to +-2e-16, and the result may not go below 0
    rng = np.random.default_rng(0)
    for _ in range(20):
        u = rng.uniform(0.1, 1.0, size=7)
        D = manifold_distances(np.column_stack([u, 3.0 * u, rng.uniform(size=7)]))
        assert D.min() >= 0.0 and D.max() <= 1.0
        assert D[0, 1] == pytest.approx(0.0, abs=1e-15)


def test_alpha_from_t_spreads_alpha_toward_one():
    np.testing.assert_allclose(alpha_from_t([0.0, 1.0, 3.0]), [0.0, 0.9, 0.999], rtol=1e-15)
    assert alpha_from_t(2) == pytest.approx(0.99)  # an integer t is a number like any other


def test_group_gram_is_the_gram_matrix_of_the_group_sums():
    X = np.random.default_rng(5).normal(size=(9, 2))
    basis = SpectralBasis.from_sq_distances(squared_distances(X), 1.0)
    alphas = np.array([0.5, 0.9])
    g = basis.gains(alphas)
    member = np.zeros((9, 2))
    member[:4, 0] = member[4:, 1] = 1.0
    inv_nu = np.random.default_rng(6).uniform(0.5, 2.0, 9)
    for a, alpha in enumerate(alphas):
        U = basis.dense_kernel(alpha) / (1.0 - alpha)  # (I - alpha S)^-1
        sums = U @ (member * inv_nu[:, None])
        np.testing.assert_allclose(
            basis.group_gram(g, a, member, inv_nu), sums.T @ sums, rtol=1e-10
        )
