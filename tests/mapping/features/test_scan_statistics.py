"""Sector and ring statistics of laser scans: values against a per-sector
loop, rotation tolerance of the ring block, the learned block scales, bad input."""

import numpy as np
import pytest
from sklearn.exceptions import NotFittedError

from mapping.features import ScanFeatures
from mapping.features.statistics import SCAN_STATISTICS, ScanStatistics, scan_statistics

MAX = 10.0


@pytest.fixture(scope="module")
def scans():
    rng = np.random.default_rng(3)
    r = rng.uniform(0.1, 14.0, size=(20, 37))  # some beyond MAX: no return
    r[:, 5] = np.inf
    r[2, 7] = np.nan
    r[4, 9] = -1.0
    return r


def _loop_reference(scan, bounds, min_range):
    """Each sector statistic by a plain loop over the sectors between ``bounds``."""
    r = np.where(np.isnan(scan) | (scan < 0), MAX, np.minimum(scan, MAX))
    out = {k: [] for k in ("mean", "min", "std", "no_return", "inverse")}
    for part in np.split(r, bounds):
        out["mean"].append(np.mean(part / MAX))
        out["min"].append(np.min(part / MAX))
        out["std"].append(np.std(part / MAX))
        out["no_return"].append(np.mean(part >= MAX))
        out["inverse"].append(np.mean(min_range / np.maximum(part, min_range)))
    return out


def test_sector_statistics_match_a_loop_over_sectors(scans):
    names = ("mean", "min", "std", "no_return", "inverse")
    blocks = scan_statistics(scans, MAX, names, n_sectors=5, min_range=0.3)
    assert [b.shape for b in blocks] == [(20, 5)] * 5
    # 37 beams in 5 sectors of 7, 7, 8, 7, 8 beams
    for i in (0, 2, 4, 11):
        ref = _loop_reference(scans[i], [7, 14, 22, 29], 0.3)
        for name, block in zip(names, blocks, strict=True):
            np.testing.assert_allclose(block[i], ref[name], atol=1e-12, err_msg=name)
    # inf, NaN and negative readings are "nothing seen": every scan has beam 5 without return
    no_return = blocks[3]
    assert np.all(no_return[:, 0] >= 1 / 7)  # beam 5 is in the first sector (beams 0-6)


def test_rings_count_returns_in_geometric_rings():
    scan = np.array([0.1, 0.3, 0.9, 2.0, 9.9, 10.0, np.inf, np.nan])
    (rings,) = scan_statistics(scan, 10.0, ("rings",), n_rings=2, min_range=0.1)
    # edges 0.1, 1, 10: 0.1 / 0.3 / 0.9 in ring 0, 2.0 / 9.9 in ring 1, the rest no return
    np.testing.assert_allclose(rings, [[3 / 8, 2 / 8]])
    # nearer than min_range joins the first ring, not a ring of its own
    (near,) = scan_statistics([0.01, 5.0], 10.0, "rings", n_rings=2, min_range=0.1)
    np.testing.assert_allclose(near, [[0.5, 0.5]])


def test_ring_block_ignores_a_turn_the_range_vector_does_not(scans):
    turned = np.roll(scans, 4, axis=1)  # the robot turned by four beams
    (a,) = scan_statistics(scans, MAX, ("rings",))
    (b,) = scan_statistics(turned, MAX, ("rings",))
    np.testing.assert_allclose(a, b, atol=1e-12)
    ranges = ScanFeatures(MAX).fit(scans)
    assert np.abs(ranges.transform(scans) - ranges.transform(turned)).max() > 0.1


def test_block_scaling_gives_each_block_unit_spread_on_the_training_scans(scans):
    feats = ScanStatistics(MAX, n_sectors=6, n_rings=4).fit(scans[:12])
    Z = feats.transform(scans[:12])
    widths = [6] * 5 + [4]
    assert Z.shape == (12, sum(widths)) and len(feats.block_scales_) == len(SCAN_STATISTICS)
    for block in np.split(Z, np.cumsum(widths)[:-1], axis=1):
        assert np.sqrt(block.var(axis=0).sum()) == pytest.approx(1.0)
    # the scales come from the training scans only: new scans are not rescaled
    raw = np.hstack(scan_statistics(scans[12:], MAX, n_sectors=6, n_rings=4))
    unscaled = ScanStatistics(MAX, n_sectors=6, n_rings=4, block_scaling=False).fit(scans[:12])
    np.testing.assert_array_equal(unscaled.block_scales_, 1.0)
    np.testing.assert_allclose(unscaled.transform(scans[12:]), raw)
    scale = np.repeat(feats.block_scales_, widths)
    np.testing.assert_allclose(feats.transform(scans[12:]), raw / scale)


def test_a_constant_block_keeps_its_units():
    scans = np.tile(np.linspace(1.0, 4.0, 8), (5, 1))
    scans[:, 0] = [1.0, 1.5, 2.0, 2.5, 3.0]  # only the first beam varies
    feats = ScanStatistics(10.0, ("min", "no_return"), n_sectors=2).fit(scans)
    assert feats.block_scales_[1] == 1.0  # no beam is ever without return
    assert np.isfinite(feats.transform(scans)).all()


def test_max_range_from_the_training_scans(scans):
    feats = ScanStatistics(statistics=("mean",), n_sectors=3).fit(scans)
    assert feats.max_range_ == pytest.approx(np.nanmax(scans[np.isfinite(scans)]))


def test_bad_input(scans):
    with pytest.raises(ValueError, match="statistics must be a non-empty list"):
        ScanStatistics(MAX, ("mean", "median")).fit(scans)
    with pytest.raises(ValueError, match="statistics must be a non-empty list"):
        ScanStatistics(MAX, ("mean", "mean")).fit(scans)
    with pytest.raises(ValueError, match="statistics must be a non-empty list"):
        scan_statistics(scans, MAX, ())
    with pytest.raises(ValueError, match="n_sectors must be in"):
        ScanStatistics(MAX, n_sectors=38).fit(scans)
    with pytest.raises(ValueError, match="min_range must be in"):
        ScanStatistics(MAX, min_range=MAX).fit(scans)
    with pytest.raises(ValueError, match="'n_rings' parameter of ScanStatistics"):
        ScanStatistics(MAX, n_rings=0).fit(scans)
    with pytest.raises(ValueError, match="n_rings must be a positive integer"):
        scan_statistics(scans, MAX, n_rings=2.5)
    with pytest.raises(ValueError, match="'block_scaling' parameter of ScanStatistics"):
        ScanStatistics(MAX, block_scaling="yes").fit(scans)
    with pytest.raises(NotFittedError, match="not fitted"):
        ScanStatistics(MAX).transform(scans)
    feats = ScanStatistics(MAX).fit(scans)
    with pytest.raises(ValueError, match="X has 30 features, but ScanStatistics is expecting 37"):
        feats.transform(scans[:, :30])
    with pytest.raises(ValueError, match="no finite positive reading"):
        ScanStatistics().fit(np.full((3, 4), np.inf))
