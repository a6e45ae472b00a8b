"""The label-free baselines: eigengap-chosen sigma for NCut and k for scikit-learn's kNN graph."""

import numpy as np
import pytest
from sklearn.cluster import SpectralClustering
from sklearn.exceptions import NotFittedError
from sklearn.metrics import adjusted_rand_score
from sklearn.utils.estimator_checks import parametrize_with_checks

from mapping.baselines.label_free import EigengapNCutClustering, KNNSpectralClustering, eigengap
from mapping.metrics import clustering_error


def _blobs(rng, n=30, centres=((0, 0), (4, 0), (0, 4))):
    X = np.concatenate([rng.normal(c, 0.3, size=(n, 2)) for c in centres])
    return X, np.repeat(np.arange(len(centres)), n)


def test_eigengap_of_k_disconnected_blocks_is_one():
    W = np.kron(np.eye(3), np.ones((4, 4)))
    np.fill_diagonal(W, 0.0)
    # each complete block of 4 has eigenvalues 1 and -1/3 (three times)
    assert eigengap(W, 3) == pytest.approx(4 / 3, abs=1e-9)
    assert eigengap(W, 2) == pytest.approx(0.0, abs=1e-9)  # lambda_2 = lambda_3 = 1
    with pytest.raises(ValueError, match="n_clusters must be in"):
        eigengap(W, 12)


def test_eigengap_ncut_finds_blobs_without_labels():
    X, y = _blobs(np.random.default_rng(0))
    model = EigengapNCutClustering(3).fit(X)
    assert clustering_error(y, model.labels_) == 0.0
    assert model.gaps_.argmax() == np.flatnonzero(model.sigmas_ == model.sigma_)[0]
    Xn, yn = _blobs(np.random.default_rng(1))
    assert clustering_error(yn, model.predict(Xn)) == 0.0


def test_knn_spectral_default_is_sklearns():
    X, _ = _blobs(np.random.default_rng(2))
    ours = KNNSpectralClustering(3).fit(X)
    theirs = SpectralClustering(3, affinity="nearest_neighbors", random_state=0).fit(X)
    assert adjusted_rand_score(theirs.labels_, ours.labels_) == 1.0
    assert ours.n_neighbors_ == 10 and ours.gaps_ == {}


def test_knn_spectral_eigengap_picks_a_candidate_and_predicts():
    X, y = _blobs(np.random.default_rng(3))
    model = KNNSpectralClustering(3, "eigengap", candidates=(3, 5, 40)).fit(X)
    assert set(model.gaps_) == {3, 5, 40}
    assert model.n_neighbors_ == max(model.gaps_, key=model.gaps_.get)
    assert clustering_error(y, model.labels_) == 0.0
    Xn, yn = _blobs(np.random.default_rng(4))
    assert clustering_error(yn, model.predict(Xn)) == 0.0


def test_knn_spectral_refuses_bad_settings():
    X, _ = _blobs(np.random.default_rng(5), n=4)
    with pytest.raises(ValueError, match="n_neighbors=20 must be < n_samples"):
        KNNSpectralClustering(3, 20).fit(X)
    with pytest.raises(ValueError, match="candidates: no neighbour count below n_samples"):
        KNNSpectralClustering(3, "eigengap", candidates=(50,)).fit(X)
    with pytest.raises(NotFittedError):
        KNNSpectralClustering(3).predict(X)


@parametrize_with_checks(
    [KNNSpectralClustering(2, 5), EigengapNCutClustering(2, n_sigmas=4, n_init=2)]
)
def test_sklearn_estimator_checks(estimator, check):
    check(estimator)


@pytest.mark.parametrize("scale", [1e200, 1e-200])
def test_a_span_float64_distances_cannot_hold_is_refused(scale):
    """EigengapNCut said 'all samples are identical'; KNN returned error 0.62 silently."""
    X, _ = _blobs(np.random.default_rng(6))
    for model in (EigengapNCutClustering(3), KNNSpectralClustering(3)):
        with pytest.raises(ValueError, match="X: the samples span .*rescale X"):
            model.fit(X * scale)


def test_fewer_distinct_samples_than_clusters_is_a_clear_error():
    X = np.vstack([np.zeros((20, 2)), np.ones((20, 2))])
    match = "n_clusters=3 needs at least 3 distinct samples in X; it has 2 groups"
    for model in (
        EigengapNCutClustering(3),
        KNNSpectralClustering(3),
        KNNSpectralClustering(3, "eigengap"),
    ):
        with pytest.raises(ValueError, match=match):
            model.fit(X)
    with pytest.raises(ValueError, match="all samples are identical"):
        KNNSpectralClustering(2).fit(np.ones((9, 2)))


def test_eigengap_survives_lapacks_subset_solver_failing():
    """Copies of two points: at some sigma LAPACK's syevr fails ('Internal Error') on the
    clustered spectrum; the full solver gives the gaps instead."""
    X = np.vstack([np.zeros((20, 2)), np.ones((20, 2))])
    model = EigengapNCutClustering(2).fit(X)
    assert clustering_error(np.repeat([0, 1], 20), model.labels_) == 0.0
    assert np.isfinite(model.gaps_).all()
