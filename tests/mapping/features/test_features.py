"""Image and laser-scan features: shapes, value ranges, invariances, robustness to inf/NaN."""

import cv2
import numpy as np
import pytest
from sklearn.exceptions import NotFittedError

from mapping.features import (
    ImageFeatures,
    ScanFeatures,
    images_to_vectors,
    normalize_rows,
    scan_ranges,
    scan_vectors,
)


@pytest.fixture(scope="module")
def images():
    rng = np.random.default_rng(0)
    return rng.integers(0, 256, size=(12, 24, 32, 3), dtype=np.uint8)


def test_images_to_vectors_raw_pixels_in_unit_range(images):
    X = images_to_vectors(images)
    assert X.shape == (12, 24 * 32 * 3) and X.dtype == np.float64
    np.testing.assert_allclose(X[3], images[3].ravel() / 255.0)


def test_resize_is_area_averaging_and_grey_is_bt601(images):
    X = images_to_vectors(images, size=(8, 6), color=False)
    assert X.shape == (12, 48)
    # A 4x4 block average of the BT.601 luma, as INTER_AREA does for an integer factor.
    luma = images[0].astype(np.float64) @ [0.299, 0.587, 0.114] / 255.0
    expected = luma.reshape(6, 4, 8, 4).mean(axis=(1, 3)).ravel()
    np.testing.assert_allclose(X[0], expected, atol=1e-5)
    single = images_to_vectors(images[0], size=(8, 6))
    ref = cv2.resize(images[0], (8, 6), interpolation=cv2.INTER_AREA).ravel() / 255.0
    np.testing.assert_allclose(single[0], ref, atol=1 / 255.0)


def test_accepts_single_grey_and_grey_batches(images):
    grey = images[..., 0]
    assert images_to_vectors(grey[0]).shape == (1, 24 * 32)
    assert images_to_vectors(grey).shape == (12, 24 * 32)
    assert images_to_vectors(grey.astype(np.float32) / 255.0, size=(4, 3)).shape == (12, 12)


def test_unit_normalisation_is_brightness_and_contrast_invariant(images):
    x = images[0].astype(np.float64) / 255.0
    a = ImageFeatures(normalization="unit").fit_transform(x * 0.5)
    b = ImageFeatures(normalization="unit").fit_transform(x * 0.5 + 0.2)
    np.testing.assert_allclose(a, b, atol=1e-12)
    np.testing.assert_allclose(np.linalg.norm(a, axis=1), 1.0)
    np.testing.assert_allclose(a.mean(axis=1), 0.0, atol=1e-12)
    # A flat image has no contrast to normalise: zeros, not NaN.
    np.testing.assert_array_equal(normalize_rows(np.full((1, 5), 0.3)), 0.0)


def test_standardize_uses_training_statistics(images):
    feats = ImageFeatures(size=(8, 6), normalization="standardize").fit(images[:8])
    Z = feats.transform(images[:8])
    np.testing.assert_allclose(Z.mean(axis=0), 0.0, atol=1e-12)
    np.testing.assert_allclose(Z.std(axis=0), 1.0)
    assert not np.allclose(feats.transform(images[8:]).mean(axis=0), 0.0)


def test_pca_projection_orthonormal_deterministic_and_sign_fixed(images):
    feats = ImageFeatures(size=(8, 6), n_components=5).fit(images)
    Z = feats.transform(images)
    assert Z.shape == (12, 5)
    np.testing.assert_allclose(feats.components_ @ feats.components_.T, np.eye(5), atol=1e-12)
    assert np.all(np.diff(feats.explained_variance_) <= 0)
    np.testing.assert_allclose(Z.var(axis=0, ddof=1), feats.explained_variance_)
    top = np.abs(feats.components_).argmax(axis=1)
    assert np.all(feats.components_[np.arange(5), top] > 0)
    # negated images (255 - x): the same axes up to sign, and the same sign rule holds
    negated = ImageFeatures(size=(8, 6), n_components=2).fit(255 - images)
    comps = negated.components_
    assert np.all(comps[np.arange(2), np.abs(comps).argmax(axis=1)] > 0)
    np.testing.assert_allclose(np.abs(comps @ feats.components_[:2].T), np.eye(2), atol=1e-9)
    # fitted state is plain arrays (servo/estimator_io saves them), not a PCA object
    assert not any(hasattr(v, "fit") for v in vars(feats).values())
    np.testing.assert_array_equal(
        Z, ImageFeatures(size=(8, 6), n_components=5).fit_transform(images)
    )


def test_image_features_bad_input(images):
    with pytest.raises(ValueError, match="'normalization' parameter of ImageFeatures must be"):
        ImageFeatures(normalization="l2").fit(images)
    with pytest.raises(NotFittedError, match="not fitted"):
        ImageFeatures().transform(images)
    with pytest.raises(ValueError, match="fitted with"):
        ImageFeatures(size=(8, 6)).fit(images).transform(images[..., 0])
    with pytest.raises(ValueError, match="n_components=50 must be between"):
        ImageFeatures(n_components=50).fit(images)
    with pytest.raises(ValueError, match="size must be"):
        images_to_vectors(images, size=(0, 4))
    with pytest.raises(ValueError, match="size must be"):
        ImageFeatures(size=(8,)).fit(images)
    with pytest.raises(ValueError, match="'method' parameter of normalize_rows"):
        normalize_rows(np.zeros((2, 3)), "l2")
    with pytest.raises(ValueError, match="images must have shape"):
        images_to_vectors(np.zeros((2, 4, 4, 4)))
    with pytest.raises(ValueError, match="NaN or inf"):
        images_to_vectors(np.full((4, 4), np.nan))
    with pytest.raises(ValueError, match="empty"):
        images_to_vectors(np.zeros((0, 4, 4)))


RAW = np.array([1.0, np.inf, np.nan, 12.0, -1.0, 3.0], dtype=np.float32)


def test_scan_ranges_makes_no_return_and_invalid_max_range():
    r = scan_ranges(RAW, max_range=10.0)
    np.testing.assert_array_equal(r, [[1.0, 10.0, 10.0, 10.0, 10.0, 3.0]])
    assert r.dtype == np.float64
    with pytest.raises(ValueError, match="max_range"):
        scan_ranges(RAW, max_range=np.inf)
    with pytest.raises(ValueError, match="ranges must have shape"):
        scan_ranges(np.zeros((2, 3, 4)), 5.0)


def test_range_and_inverse_representations():
    rng_feat = scan_vectors(RAW, 10.0, "range")
    np.testing.assert_allclose(rng_feat, [[0.1, 1, 1, 1, 1, 0.3]])
    inv = scan_vectors(RAW, 10.0, "inverse", min_range=0.5)
    np.testing.assert_allclose(inv[0, [1, 2]], 0.0)  # no return / invalid -> 0
    np.testing.assert_allclose(inv[0, 0], 0.5 - 0.05)
    assert inv[0, 0] > inv[0, 5] > 0  # nearer obstacle, larger feature


def test_sectors_keep_the_nearest_return():
    scans = np.array([[5.0, 1.0, np.inf, 2.0, 4.0, np.nan], [9.0, 9.0, 9.0, 9.0, 0.5, 9.0]])
    out = scan_vectors(scans, 10.0, n_sectors=3)
    np.testing.assert_allclose(out, [[0.1, 0.2, 0.4], [0.9, 0.9, 0.05]])


def test_polar_grid_counts_fraction_of_beams_per_cell():
    scan = np.array([0.5, 1.5, np.inf, 3.9, 2.0, 2.1, np.nan, 0.1])
    grid = scan_vectors(scan, 4.0, "polar_grid", n_sectors=2, n_range_bins=4).reshape(2, 4)
    np.testing.assert_allclose(grid, [[0.25, 0.25, 0.0, 0.25], [0.25, 0.0, 0.5, 0.0]])
    batch = scan_vectors(np.stack([scan, scan[::-1]]), 4.0, "polar_grid", n_range_bins=4)
    assert batch.shape == (2, 8 * 4)  # default 16 sectors, capped at the 8 beams
    # One beam per sector: each of the 6 returns fills one cell; inf and NaN fill none.
    np.testing.assert_allclose(batch.sum(axis=1), 6.0)


def test_scan_features_fit_transform_and_bad_input():
    rng = np.random.default_rng(0)
    scans = rng.uniform(0.2, 12.0, size=(5, 360)).astype(np.float32)
    scans[:, ::7] = np.inf
    feats = ScanFeatures(max_range=10.0, representation="inverse", n_sectors=36)
    out = feats.fit_transform(scans)
    assert out.shape == (5, 36) and np.isfinite(out).all()
    assert feats.n_features_in_ == 360 and feats.max_range_ == 10.0
    np.testing.assert_array_equal(feats.transform(scans[:1]), out[:1])
    with pytest.raises(ValueError, match="X has 100 features, but ScanFeatures is expecting 360"):
        feats.transform(scans[:, :100])
    with pytest.raises(ValueError, match="Reshape your data"):
        feats.transform(scans[0])  # one scan is a batch of one, as in scikit-learn
    with pytest.raises(NotFittedError, match="not fitted"):
        ScanFeatures(10.0).transform(scans)
    with pytest.raises(ValueError, match="'representation' parameter of ScanFeatures must be"):
        ScanFeatures(10.0, "occupancy").fit(scans)
    with pytest.raises(ValueError, match="'representation' parameter of scan_vectors must be"):
        scan_vectors(scans, 10.0, "occupancy")
    with pytest.raises(ValueError, match="'max_range' parameter"):
        ScanFeatures(-1.0).fit(scans)
    with pytest.raises(ValueError, match="n_sectors must be in"):
        ScanFeatures(10.0, n_sectors=400).fit(scans)
    with pytest.raises(ValueError, match="min_range must be in"):
        ScanFeatures(10.0, "inverse", min_range=20.0).fit(scans)


def test_scan_features_max_range_from_the_training_scans():
    scans = np.array([[1.0, np.inf, 4.0, np.nan], [2.5, 6.0, -1.0, np.inf]])
    feats = ScanFeatures().fit(scans)
    assert feats.max_range_ == 6.0  # the largest finite reading; inf, NaN and -1 ignored
    np.testing.assert_allclose(feats.transform(scans), scan_vectors(scans, 6.0))
    with pytest.raises(ValueError, match="no finite positive reading"):
        ScanFeatures().fit(np.full((2, 3), np.inf))


def test_color_histograms_match_opencv_calchist_per_cell(images):

    from mapping.features import color_histograms

    feats = color_histograms(images, bins=(8, 4, 4), grid=(2, 1))
    assert feats.shape == (len(images), 2 * 128)
    for k, im in enumerate(images):
        hsv = cv2.cvtColor(im, cv2.COLOR_RGB2HSV)
        half = im.shape[1] // 2
        for c, part in enumerate((hsv[:, :half], hsv[:, half:])):
            h = cv2.calcHist([part], [0, 1, 2], None, [8, 4, 4], [0, 180, 0, 256, 0, 256])
            expected = np.sqrt(h.ravel() / h.sum())
            np.testing.assert_allclose(feats[k, c * 128 : (c + 1) * 128], expected, atol=1e-6)
    # every cell's part has unit norm
    np.testing.assert_allclose(np.linalg.norm(feats.reshape(len(images), 2, -1), axis=2), 1.0)


def test_color_histogram_features_interface_and_bad_input(images):
    from mapping import ColorHistogramFeatures

    model = ColorHistogramFeatures(bins=(4, 2, 2), grid=(1, 1))
    with pytest.raises(NotFittedError, match="not fitted"):
        model.transform(images)
    X = model.fit_transform(images)
    assert X.shape == (len(images), 16) and model.n_features_in_ == 16
    np.testing.assert_array_equal(model.transform(images[0]), X[:1])
    with pytest.raises(ValueError, match="uint8 RGB"):
        ColorHistogramFeatures().fit(images.astype(np.float32))
    with pytest.raises(ValueError, match="bins"):
        ColorHistogramFeatures(bins=(0, 2, 2)).fit(images)
    with pytest.raises(ValueError, match="grid"):
        ColorHistogramFeatures(grid=(2,)).fit(images)


def test_color_histogram_features_fit_on_one_image(images):
    """One (H, W, 3) image is a batch of one in fit, as in transform (fit took images[:1], its
    first pixel row, and refused it as a 32x1 image)."""
    from mapping import ColorHistogramFeatures

    model = ColorHistogramFeatures()
    np.testing.assert_array_equal(model.fit_transform(images[0]), model.transform(images[:1]))
    assert model.fit(images[0]).n_features_in_ == 512
    with pytest.raises(ValueError, match="images is empty"):
        ColorHistogramFeatures().fit(images[:0])
    with pytest.raises(ValueError, match="images is empty"):
        ColorHistogramFeatures().fit(images).transform(images[:0])
    for bins in ((4.5, 4, 4), (8, 4), np.array([8.0, 4, 4])):  # 4.5 was truncated to 4
        with pytest.raises(ValueError, match="bins must be three positive ints"):
            ColorHistogramFeatures(bins=bins).fit(images)


def test_pixel_values_are_scaled_to_the_unit_range_by_one_rule(images):
    """uint8 by 1/255, uint16 by 1/65535, 8-bit values in a wider type or as floats like
    uint8, floats in [0, 1] as they are; anything else is refused."""
    u8 = images_to_vectors(images)
    np.testing.assert_array_equal(images_to_vectors(images.astype(np.int64)), u8)
    np.testing.assert_allclose(images_to_vectors(images.astype(np.float64)), u8, rtol=1e-15)
    np.testing.assert_allclose(images_to_vectors(images / 255.0), u8, rtol=1e-15)
    deep = images.astype(np.uint16) * 257  # 0-255 stretched to 0-65535
    np.testing.assert_allclose(images_to_vectors(deep), u8, rtol=1e-6)
    assert images_to_vectors(np.full((2, 4, 4, 3), 65535, np.uint16)).max() == 1.0
    for bad, match in [
        (images.astype(np.int64) + 1, r"int64 values in \[1, 256\]"),
        (images.astype(np.int16) - 1, r"int16 values in \[-1"),
        (images * 300.0, r"float64 values in \[0.0, 76500.0\]"),
        (images > 0, "got dtype bool"),
    ]:
        with pytest.raises(ValueError, match="images must be uint8, uint16, .*" + match):
            images_to_vectors(bad)
    with pytest.raises(ValueError, match="images must be uint8"):
        ImageFeatures().fit(images * 300.0)


def test_image_shapes_rgba_empty_and_sizes(images):
    rgba = np.concatenate([images[0], images[0, ..., :1]], axis=-1)  # one (H, W, 4) image
    with pytest.raises(ValueError, match=r"got \(24, 32, 4\): RGBA\? pass images\[\.\.\., :3\]"):
        images_to_vectors(rgba)
    with pytest.raises(ValueError, match=r"images must have shape .*: RGBA\?"):
        ImageFeatures().fit(rgba[None])
    assert images_to_vectors(images[..., 0]).shape == (12, 24 * 32)  # a grey batch still
    with pytest.raises(ValueError, match="images must have pixels, got 24x0"):
        images_to_vectors(images[:, :, :0], size=(8, 6))
    for size in ("32", (8.7, 6), (8, 6.0), (True, 6), (8, 6, 1), 8):
        with pytest.raises(ValueError, match=r"size must be \(width, height\) of positive ints"):
            images_to_vectors(images, size=size)
    assert images_to_vectors(images, size=np.array([8, 6])).shape == (12, 144)


def test_normalize_rows_needs_rows_and_pca_two_images(images):
    with pytest.raises(ValueError, match=r"X must be 2-D, one vector per row \(X\[None\]"):
        normalize_rows(np.arange(5.0))
    X = np.ones((3, 4))
    X[1, 2] = np.nan  # was a row of zeros, read downstream as a constant image
    with pytest.raises(ValueError, match=r"X must be finite; rows \[1\] hold NaN or inf"):
        normalize_rows(X)
    X[1, 2] = np.inf
    with pytest.raises(ValueError, match="X must be finite"):
        normalize_rows(X, "none")
    with pytest.raises(ValueError, match="n_components=1 needs at least 2 training images"):
        ImageFeatures(n_components=1).fit(images[:1])  # no 'invalid value in divide'
    assert ImageFeatures(n_components=1).fit(images[:2]).transform(images).shape == (12, 1)
