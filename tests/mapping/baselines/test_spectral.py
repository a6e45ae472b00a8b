"""Spectral baselines: NCut with one sigma, the oracle sigma sweep, self-tuning, Nystrom predict."""

import numpy as np
import pytest
from sklearn.cluster import SpectralClustering
from sklearn.exceptions import NotFittedError
from sklearn.metrics import adjusted_rand_score

from mapping.baselines import NormalizedCutClustering, SelfTuningSpectralClustering
from mapping.baselines.sigma_sweep import best_sigma_ncut
from mapping.distances import squared_distances
from mapping.manifold import converging_paths, parallel_lines
from mapping.metrics import clustering_error


@pytest.fixture(scope="module")
def lines():
    return parallel_lines(n_per_line=40, gap=0.2, length=1.0)


def _blobs(rng, n=30, centres=((0, 0), (3, 0), (0, 3))):
    X = np.concatenate([rng.normal(c, 0.3, size=(n, 2)) for c in centres])
    return X, np.repeat(np.arange(len(centres)), n)


def test_squared_distances_exact_for_near_duplicates_far_from_origin():
    A = np.array([[1e4, 1e4], [1e4 + 1e-3, 1e4], [1e4, 1e4 - 2e-3]])
    exact = ((A[:, None] - A[None]) ** 2).sum(axis=2)
    D2 = squared_distances(A)
    np.testing.assert_allclose(D2, exact, rtol=1e-6, atol=1e-12)
    np.testing.assert_array_equal(np.diag(D2), 0.0)
    np.testing.assert_array_equal(D2, D2.T)
    np.testing.assert_allclose(squared_distances(A[:1], A), exact[:1], rtol=1e-6, atol=1e-12)


def test_ncut_separates_parallel_lines_and_matches_sklearn(lines):
    X, y = lines
    model = NormalizedCutClustering(3, sigma=0.05).fit(X)
    assert clustering_error(y, model.labels_) == 0.0
    sk = SpectralClustering(3, gamma=1 / (2 * 0.05**2), random_state=0).fit(X)
    assert adjusted_rand_score(sk.labels_, model.labels_) == 1.0
    np.testing.assert_array_equal(np.diag(model.affinity_matrix_), 0.0)
    assert model.eigenvalues_[0] == pytest.approx(1.0)
    assert np.all(np.diff(model.eigenvalues_) <= 0)


def test_ncut_too_wide_sigma_fails_on_parallel_lines(lines):
    # The error must depend on sigma for the sweep to mean anything.
    X, y = lines
    assert clustering_error(y, NormalizedCutClustering(3, sigma=1.0).fit(X).labels_) > 0.2


def test_fit_is_deterministic_float32_safe_and_row_order_invariant(lines):
    X, _ = lines
    a = NormalizedCutClustering(3, sigma=0.05).fit(X).labels_
    np.testing.assert_array_equal(a, NormalizedCutClustering(3, sigma=0.05).fit(X).labels_)
    b = NormalizedCutClustering(3, sigma=0.05).fit(X.astype(np.float32)).labels_
    assert adjusted_rand_score(a, b) == 1.0
    perm = np.random.default_rng(0).permutation(len(X))
    c = NormalizedCutClustering(3, sigma=0.05).fit(X[perm]).labels_
    assert clustering_error(a[perm], c) == 0.0


def test_best_sigma_ncut_solves_parallel_lines_and_reports_the_sweep(lines):
    X, y = lines
    sweep = best_sigma_ncut(X, y, 3)
    assert sweep.error == 0.0
    assert clustering_error(y, sweep.model.labels_) == 0.0
    assert sweep.model.sigma == sweep.sigma
    assert sweep.errors.shape == sweep.sigmas.shape == (40,)
    assert sweep.errors.min() == sweep.error
    # Too-wide sigmas are in the default grid and do fail, so the choice was not free.
    assert sweep.errors.max() > 0.2
    tied = sweep.sigmas[sweep.errors == 0.0]
    assert tied.min() < sweep.sigma < tied.max()


def test_best_sigma_ncut_uses_given_grid_and_cannot_solve_converging_paths():
    X, y = converging_paths()
    sigmas = [0.01, 0.02, 0.04, 0.08]
    sweep = best_sigma_ncut(X, y, 3, sigmas=sigmas, n_init=3)
    np.testing.assert_array_equal(sweep.sigmas, sigmas)
    assert sweep.sigma in sigmas
    # The paths share their start: no single sigma separates them (paper, Figure 4b).
    assert 0.05 < sweep.error < 0.6


def test_self_tuning_clusters_blobs_of_different_spread():
    rng = np.random.default_rng(1)
    X = np.concatenate(
        [
            rng.normal((0, 0), 0.05, (40, 2)),
            rng.normal((2, 0), 0.5, (40, 2)),
            rng.normal((6, 6), 0.2, (40, 2)),
        ]
    )
    y = np.repeat(np.arange(3), 40)
    model = SelfTuningSpectralClustering(3).fit(X)
    assert clustering_error(y, model.labels_) == 0.0
    # sigma_i is the distance to the 7th neighbour: small in the tight blob, large in the wide one.
    assert np.median(model.scales_[:40]) < 0.3 * np.median(model.scales_[40:80])
    D2 = squared_distances(X)
    np.testing.assert_allclose(model.scales_, np.sqrt(np.sort(D2, axis=1)[:, 7]))


@pytest.mark.parametrize(
    "model", [NormalizedCutClustering(3, sigma=0.05), SelfTuningSpectralClustering(3)]
)
def test_predict_held_out_points(model):
    # Wider gap than the fixture: with every second point the local scales double.
    X, y = parallel_lines(n_per_line=40, gap=0.5, length=1.0)
    train, test = np.arange(0, len(X), 2), np.arange(1, len(X), 2)
    model.fit(X[train])
    mapping = {p: t for p, t in zip(model.labels_, y[train], strict=True)}
    assert clustering_error(y[train], model.labels_) == 0.0
    predicted = np.array([mapping[p] for p in model.predict(X[test])])
    np.testing.assert_array_equal(predicted, y[test])
    np.testing.assert_array_equal(model.predict(X[train]), model.labels_)


def test_nystrom_embedding_reproduces_training_rows():
    rng = np.random.default_rng(2)
    X, _ = _blobs(rng, n=60)
    model = NormalizedCutClustering(3, sigma=2.0).fit(X)
    # Only the self-affinity, which training leaves out, differs: small for large degrees.
    np.testing.assert_allclose(model.transform(X), model.embedding_, atol=0.05)


def test_far_point_takes_its_nearest_neighbours_label(lines):
    X, _ = lines
    model = NormalizedCutClustering(3, sigma=0.01).fit(X)
    far = np.array([[0.5, 100.0], [0.5, -100.0]])  # nearest to the top and bottom line
    labels = model.predict(far)
    assert labels[0] == model.labels_[np.argmax(X[:, 1])]
    assert labels[1] == model.labels_[np.argmin(X[:, 1])]


def test_tiny_sigma_raises_cleanly_without_runtime_warnings(lines):
    X, _ = lines
    with pytest.raises(ValueError, match="underflows"):
        NormalizedCutClustering(3, sigma=1e-6).fit(X)
    # A small sigma isolates some points (degree underflows) yet must not warn or crash.
    X2 = np.concatenate([X, [[5.0, 5.0]]])
    labels = NormalizedCutClustering(3, sigma=0.004).fit(X2).labels_
    assert labels.shape == (len(X2),)


@pytest.mark.parametrize(
    ("make", "X", "match"),
    [
        (lambda: NormalizedCutClustering(0, sigma=0.1), None, "'n_clusters' parameter of Norm"),
        (lambda: NormalizedCutClustering(2.5, sigma=0.1), None, "'n_clusters' parameter"),
        (lambda: NormalizedCutClustering(200, sigma=0.1), None, "n_clusters=200 exceeds"),
        (lambda: NormalizedCutClustering(3, sigma=0.0), None, "'sigma' parameter"),
        (lambda: NormalizedCutClustering(3, sigma=np.inf), None, "'sigma' parameter"),
        (lambda: NormalizedCutClustering(3, sigma=np.nan), None, "'sigma' parameter"),
        (lambda: NormalizedCutClustering(3, sigma="1"), None, "'sigma' parameter"),
        (lambda: NormalizedCutClustering(3, sigma=0.1, n_init=0), None, "'n_init' parameter"),
        (lambda: NormalizedCutClustering(3, random_state=-1), None, "'random_state' parameter"),
        (lambda: SelfTuningSpectralClustering(3, n_neighbors=0), None, "'n_neighbors' parameter"),
        (lambda: SelfTuningSpectralClustering(3, n_neighbors=120), None, "n_neighbors=120"),
        (lambda: SelfTuningSpectralClustering(2), [[1.0, np.nan], [0, 0], [1, 1]], "NaN"),
        (lambda: SelfTuningSpectralClustering(2), [[1.0, 2.0]], "1 sample"),
        (lambda: SelfTuningSpectralClustering(2), [1.0, 2.0, 3.0], "2D array"),
        (lambda: SelfTuningSpectralClustering(2), [[1.0, 2.0]] * 9, "all samples are identical"),
        (lambda: NormalizedCutClustering(2, 1.0), [[1.0, 2.0]] * 9, "all samples are identical"),
    ],
)
def test_bad_input_raises(make, X, match, lines):
    data = lines[0] if X is None else np.asarray(X)
    with pytest.raises(ValueError, match=match):
        make().fit(data)


def test_predict_before_fit_and_wrong_dimension(lines):
    X, y = lines
    model = SelfTuningSpectralClustering(3)
    for call in (model.predict, model.transform):
        with pytest.raises(NotFittedError, match="not fitted yet"):
            call(X)
    model.fit(X)
    with pytest.raises(ValueError, match="X has 3 features, but SelfTuningSpectralClustering"):
        model.predict(np.zeros((2, 3)))
    with pytest.raises(ValueError, match="inconsistent numbers of samples"):
        best_sigma_ncut(X, y[:-1], 3)
    with pytest.raises(ValueError, match="sigmas must be"):
        best_sigma_ncut(X, y, 3, sigmas=[0.1, -1.0])
    with pytest.raises(ValueError, match="all-zero affinity"):
        best_sigma_ncut(X, y, 3, sigmas=[1e-7])


@pytest.mark.parametrize("scale", [1e200, 1e-200])
def test_a_span_float64_distances_cannot_hold_is_refused(lines, scale):
    """At 1e200 the squared distances overflow, at 1e-200 they underflow to 0: the fits said
    'all samples are identical' (after overflow warnings); now ManifoldClustering's check."""
    X, y = lines
    for model in (NormalizedCutClustering(3, 0.085 * scale), SelfTuningSpectralClustering(3)):
        with pytest.raises(ValueError, match="X: the samples span .*rescale X"):
            model.fit(X * scale)
    with pytest.raises(ValueError, match="rescale X"):
        best_sigma_ncut(X * scale, y, 3)


def test_fewer_distinct_samples_than_clusters_is_a_clear_error():
    """Two places, the robot stood still at each: 3 clusters would split copies of a point."""
    X = np.vstack([np.zeros((20, 2)), np.ones((20, 2))])
    y = np.repeat([0, 1], 20)
    match = "n_clusters=3 needs at least 3 distinct samples in X; it has 2 groups"
    for model in (NormalizedCutClustering(3, 0.5), SelfTuningSpectralClustering(3)):
        with pytest.raises(ValueError, match=match):
            model.fit(X)
    with pytest.raises(ValueError, match=match):
        best_sigma_ncut(X, y, 3)
    labels = SelfTuningSpectralClustering(2).fit(X).labels_  # as many places as clusters
    assert clustering_error(y, labels) == 0.0


def test_self_tuning_scales_skip_copies_of_a_point():
    """A robot standing still (30 copies of one point among 180): the copies were each
    other's nearest neighbours, so their scale fell to the floor and they became a cluster of
    their own (error 0.28); the scale is now the n_neighbors-th distinct neighbour's."""
    X, y = parallel_lines(60)
    Xd = np.vstack([X[:30], np.repeat(X[[30]], 30, axis=0), X[30:]])
    yd = np.concatenate([y[:30], np.full(30, y[30]), y[30:]])
    clean = SelfTuningSpectralClustering(3).fit(X)
    model = SelfTuningSpectralClustering(3).fit(Xd)
    assert clustering_error(yd, model.labels_) == 0.0 == clustering_error(y, clean.labels_)
    # a copy's scale is the clean point's, and predict treats new copies the same way
    np.testing.assert_allclose(model.scales_[30:61], clean.scales_[30], rtol=1e-9)
    np.testing.assert_array_equal(model.predict(X), _training_labels(model, X, Xd))
    # fewer distinct neighbours than n_neighbors: the floor, and the places still split
    few = np.vstack([np.zeros((20, 2)), np.ones((20, 2))])
    two = SelfTuningSpectralClustering(2).fit(few)
    np.testing.assert_array_equal(two.scales_, two.min_scale_)


def _training_labels(model, X, Xd):
    """The training label of each row of X (a row of the training data Xd)."""
    return np.array([model.labels_[np.flatnonzero((Xd == x).all(axis=1))[0]] for x in X])


def test_best_sigma_ncut_names_its_arguments(lines):
    X, y = lines
    with pytest.raises(ValueError, match="X and y have inconsistent numbers of samples: 120 "):
        best_sigma_ncut(X, y[:-1], 3)
    with pytest.raises(ValueError, match="y must hold a finite label for every point, got nan"):
        best_sigma_ncut(X, np.where(np.arange(len(y)) == 5, np.nan, y), 3)
    for sigmas in ("abc", [0.1, "a"], [[0.1, None]]):
        with pytest.raises(ValueError, match="sigmas must be a non-empty sequence of positive"):
            best_sigma_ncut(X, y, 3, sigmas=sigmas)
