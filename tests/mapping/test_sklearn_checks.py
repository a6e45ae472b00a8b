"""scikit-learn's own estimator checks on the estimators of ``mapping``.

The 2-D estimators run the whole suite (``parametrize_with_checks``); the image transformers
take batches of images, which the suite cannot feed (their tags say so), so they run the checks
that need no data and image versions of the others. Small search grids keep the suite quick;
the clusterings themselves are tested in test_manifold.py and test_baselines.py.
"""

import pickle

import numpy as np
import pytest
from sklearn.base import clone
from sklearn.exceptions import NotFittedError
from sklearn.pipeline import make_pipeline
from sklearn.utils import estimator_checks as ec
from sklearn.utils.estimator_checks import parametrize_with_checks
from sklearn.utils.validation import check_is_fitted

from mapping import manifold
from mapping.baselines import NormalizedCutClustering, SelfTuningSpectralClustering
from mapping.features import ScanFeatures
from mapping.features.hsv_histograms import ColorHistogramFeatures
from mapping.features.images import ImageFeatures
from mapping.features.statistics import ScanStatistics
from mapping.manifold import ManifoldClustering

ESTIMATORS = [
    ManifoldClustering(n_clusters=2, min_cluster_size=3, n_sigmas=4, n_alphas=3, refine=False),
    # the k-NN graph path, truncated above 16 points
    ManifoldClustering(
        n_clusters=2, min_cluster_size=3, n_sigmas=4, n_alphas=3, kernel="sparse", n_components=4
    ),
    NormalizedCutClustering(n_clusters=2, sigma=1.0, n_init=2),
    SelfTuningSpectralClustering(n_clusters=2, n_neighbors=5, n_init=2),
    ScanFeatures(),
    ScanFeatures(max_range=4.0, representation="polar_grid", n_range_bins=3),
    # one sector: the suite's data has as few as one feature (beam)
    ScanStatistics(n_sectors=1, n_rings=3),
]


def _expected_failed_checks(estimator) -> dict[str, str]:
    if isinstance(estimator, ManifoldClustering):
        return manifold.EXPECTED_FAILED_CHECKS
    return {}


@parametrize_with_checks(ESTIMATORS, expected_failed_checks=_expected_failed_checks)
def test_sklearn_estimator_checks(estimator, check):
    check(estimator)


def test_expected_failures_are_declared_with_a_reason():
    # ManifoldClustering passes every scikit-learn check: none is declared as failing, and the
    # declaration is what the checks above are given
    declared = manifold.EXPECTED_FAILED_CHECKS
    assert declared == {}
    assert _expected_failed_checks(ManifoldClustering()) is declared
    assert _expected_failed_checks(NormalizedCutClustering()) == {}
    # the mechanism, on a declaration made up here: the named check, and no other, is marked
    # xfail with its reason
    reason = "a made-up reason for this test of the declaration's wiring"
    mark = parametrize_with_checks(
        [ManifoldClustering()], expected_failed_checks=lambda e: {"check_fit2d_1sample": reason}
    )
    xfails = {}
    for param in mark.args[1]:
        values, marks = (param.values, param.marks) if hasattr(param, "marks") else (param, ())
        xfails[values[1].func.__name__] = [m.kwargs["reason"] for m in marks if m.name == "xfail"]
    assert len(xfails) > 30 and xfails.pop("check_fit2d_1sample") == [reason]
    assert not any(xfails.values())


# --- the image transformers ---------------------------------------------------------------
IMAGE_ESTIMATORS = [
    ImageFeatures(size=(8, 6), normalization="standardize", n_components=3),
    ImageFeatures(color=False, normalization="unit"),
    ColorHistogramFeatures(bins=(4, 2, 2), grid=(2, 1)),
]
# scikit-learn's checks that need no data: they hold for any input type
API_CHECKS = [
    ec.check_estimator_cloneable,
    ec.check_estimator_repr,
    ec.check_estimator_tags_renamed,
    ec.check_valid_tag_types,
    ec.check_no_attributes_set_in_init,
    ec.check_parameters_default_constructible,
    ec.check_get_params_invariance,
    ec.check_set_params,
    ec.check_do_not_raise_errors_in_init_or_set_params,
    ec.check_mixin_order,
]


def _ids(items):
    return [getattr(x, "__name__", type(x).__name__) for x in items]


@pytest.mark.parametrize("check", API_CHECKS, ids=_ids(API_CHECKS))
@pytest.mark.parametrize("estimator", IMAGE_ESTIMATORS, ids=_ids(IMAGE_ESTIMATORS))
def test_image_transformers_api_checks(estimator, check):
    check(type(estimator).__name__, estimator)


@pytest.fixture(scope="module")
def images():
    return np.random.default_rng(0).integers(0, 256, size=(10, 12, 16, 3), dtype=np.uint8)


@pytest.mark.parametrize("estimator", IMAGE_ESTIMATORS, ids=_ids(IMAGE_ESTIMATORS))
def test_image_transformers_fit_like_scikit_learn(estimator, images):
    """Image versions of the data checks: unfitted, fit returns self, idempotent, no
    parameter overwritten, fit_transform == fit().transform(), clone, pickle, pipeline."""
    est = clone(estimator)
    with pytest.raises(NotFittedError):
        est.transform(images)
    with pytest.raises(NotFittedError):
        check_is_fitted(est)
    params = est.get_params()
    assert est.fit(images) is est
    check_is_fitted(est)
    assert est.get_params() == params
    assert est.n_features_in_ > 0
    out = est.transform(images)
    assert out.shape[0] == len(images) and out.dtype == np.float64
    np.testing.assert_array_equal(clone(estimator).fit_transform(images), out)
    np.testing.assert_array_equal(est.fit(images).transform(images), out)  # idempotent
    # fit state is only new attributes ending in "_"
    assert not [k for k in vars(est) if k not in params and not k.endswith("_")]
    np.testing.assert_array_equal(pickle.loads(pickle.dumps(est)).transform(images), out)
    # rows are independent: a subset and a permutation give the same rows
    perm = np.random.default_rng(1).permutation(len(images))
    np.testing.assert_allclose(est.transform(images[perm]), out[perm], rtol=1e-12, atol=1e-12)
    np.testing.assert_allclose(est.transform(images[3:5]), out[3:5], rtol=1e-12, atol=1e-12)
    pipe = make_pipeline(clone(estimator), ManifoldClustering(n_clusters=2, min_cluster_size=3))
    assert pipe.fit_predict(images).shape == (len(images),)


@pytest.mark.parametrize("estimator", IMAGE_ESTIMATORS, ids=_ids(IMAGE_ESTIMATORS))
def test_image_transformers_declare_their_input(estimator):
    tags = estimator.__sklearn_tags__()
    assert not tags.input_tags.two_d_array and tags.input_tags.three_d_array
    assert tags.transformer_tags is not None and tags.requires_fit
