"""Sensor readings to fixed-length feature vectors, so both sensors feed both mapping methods.

Images: `mapping.features.images` (raw pixels as in the paper) and
`mapping.features.hsv_histograms` (per-cell HSV colour histograms).

Laser scans: float32 range arrays of shape (n_beams,) or (n, n_beams), where ``+inf`` means
"no return within max range" and NaN an invalid reading.
[`scan_ranges`][mapping.features.scans.scan_ranges] makes them finite (both become ``max_range``),
[`scan_vectors`][mapping.features.scans.scan_vectors] turns them into a range, inverse-range or
polar occupancy-grid vector, and [`ScanFeatures`][mapping.features.scans.ScanFeatures] wraps that
([`common.geometry.scan_to_points`][common.geometry.scan_to_points] gives the returns as points
instead; [`mapping.features.statistics.ScanStatistics`][mapping.features.statistics.ScanStatistics]
summarises a scan by sector and ring statistics). Everything is vectorised over scans and beams.
"""

from __future__ import annotations

from numbers import Integral, Real

import numpy as np
from numpy.typing import ArrayLike
from sklearn.base import BaseEstimator, TransformerMixin, _fit_context
from sklearn.utils._param_validation import Interval, StrOptions, validate_params
from sklearn.utils.validation import check_is_fitted, validate_data

__all__ = [
    "SCAN_REPRESENTATIONS",
    "ScanFeatures",
    "ScanRangesInput",
    "scan_ranges",
    "scan_vectors",
]

SCAN_REPRESENTATIONS = ("range", "inverse", "polar_grid")


def scan_ranges(ranges: ArrayLike, max_range: float) -> np.ndarray:
    """Return the ranges as finite values in [0, max_range].

    ``+inf`` (no return) and values beyond ``max_range`` become ``max_range``; NaN, ``-inf`` and
    negative readings are invalid and are also treated as "nothing seen" (``max_range``), the
    conservative choice that never invents an obstacle.

    Parameters
    ----------
    ranges : array-like of shape (n_beams,) or (n, n_beams)
        Raw ranges.
    max_range : float
        Sensor range limit in metres, positive and finite.

    Returns
    -------
    ndarray of shape (n, n_beams), float64
        The finite ranges.
    """
    if not (np.isfinite(max_range) and max_range > 0):
        raise ValueError(f"max_range must be a positive finite number, got {max_range!r}")
    r = np.asarray(ranges, dtype=np.float64)
    if r.ndim == 1:
        r = r[None]
    if r.ndim != 2 or r.shape[1] == 0:
        raise ValueError(f"ranges must have shape (n_beams,) or (n, n_beams), got {r.shape}")
    invalid = np.isnan(r) | (r < 0)
    return np.where(invalid, max_range, np.minimum(r, max_range))


@validate_params(
    {
        "ranges": ["array-like"],
        "max_range": [Interval(Real, 0, None, closed="neither")],
        "representation": [StrOptions(set(SCAN_REPRESENTATIONS))],
        "min_range": [Interval(Real, 0, None, closed="neither")],
        "n_sectors": [Interval(Integral, 1, None, closed="left"), None],
        "n_range_bins": [Interval(Integral, 1, None, closed="left")],
    },
    prefer_skip_nested_validation=True,
)
def scan_vectors(
    ranges: ArrayLike,
    max_range: float,
    representation: str = "range",
    *,
    min_range: float = 0.05,
    n_sectors: int | None = None,
    n_range_bins: int = 8,
) -> np.ndarray:
    """Turn scans into fixed-length vectors.

    Parameters
    ----------
    ranges : array-like of shape (n_beams,) or (n, n_beams)
        Raw ranges; inf = no return, NaN = invalid (see
        [`scan_ranges`][mapping.features.scans.scan_ranges]).
    max_range : float
        Sensor range limit in metres.
    representation : {"range", "inverse", "polar_grid"}, default "range"
        "range": ``r / max_range`` in [0, 1] per beam (or sector).
        "inverse": ``min_range / r - min_range / max_range``, which stresses near obstacles and
        maps "no return" to 0.
        "polar_grid": an occupancy histogram over (angle sector, range bin): the fraction of the
        sector's beams whose return falls in each range bin; beams without return add nothing.
    min_range : float, default 0.05
        Ranges are clipped below at this value for "inverse".
    n_sectors : int, optional
        Pool beams into this many equal angular sectors. "range"/"inverse" keep the nearest
        return per sector (min-pooling), which is robust to a single missed beam; "polar_grid"
        needs it (default 16 there). Sectors are runs of consecutive beams (beams are assumed
        to be ordered by angle, as a scanner reports them), as even as ``np.array_split``.
    n_range_bins : int, default 8
        Range bins of "polar_grid", equal width over [0, max_range).

    Returns
    -------
    ndarray of shape (n, D), float64
        One vector per scan.
    """
    r = scan_ranges(ranges, max_range)
    n, n_beams = r.shape
    if n_sectors is None and representation == "polar_grid":
        n_sectors = min(16, n_beams)
    if n_sectors is not None and not 1 <= n_sectors <= n_beams:
        raise ValueError(f"n_sectors must be in [1, n_beams={n_beams}], got {n_sectors!r}")
    # First beam of each sector; np.minimum.reduceat pools each sector in one call.
    starts = np.linspace(0, n_beams, (n_sectors or n_beams) + 1).astype(int)[:-1]

    if representation == "polar_grid":
        sector = np.repeat(np.arange(n_sectors), np.diff(np.append(starts, n_beams)))
        rbin = np.minimum((r / max_range * n_range_bins).astype(int), n_range_bins - 1)
        hit = r < max_range
        cell = (np.arange(n)[:, None] * n_sectors + sector[None, :]) * n_range_bins + rbin
        grid = np.bincount(cell[hit], minlength=n * n_sectors * n_range_bins).astype(np.float64)
        grid = grid.reshape(n, n_sectors, n_range_bins)
        beams_per_sector = np.bincount(sector, minlength=n_sectors).astype(np.float64)
        return (grid / beams_per_sector[None, :, None]).reshape(n, -1)

    if n_sectors is not None:
        r = np.minimum.reduceat(r, starts, axis=1)
    if representation == "range":
        return r / max_range
    if not 0 < min_range < max_range:
        raise ValueError(f"min_range must be in (0, max_range={max_range}), got {min_range!r}")
    return min_range / np.maximum(r, min_range) - min_range / max_range


def fitted_max_range(ranges: np.ndarray, max_range: float | None) -> float:
    """Return the laser's range limit (a scan transformer's ``max_range_``).

    ``max_range`` when given, else the largest finite positive reading of the training scans.

    Parameters
    ----------
    ranges : ndarray of shape (n, n_beams)
        Training scans.
    max_range : float or None
        The limit given by the user, if any.

    Returns
    -------
    float
        The range limit in metres.
    """
    if max_range is not None:
        return float(max_range)
    seen = ranges[np.isfinite(ranges) & (ranges > 0)]
    if seen.size == 0:
        raise ValueError(
            "ranges has no finite positive reading to take max_range from; pass max_range"
        )
    return float(seen.max())


class ScanRangesInput:
    """Input handling shared by the scan transformers.

    Rows of ranges (n, n_beams) in which inf (no return) and NaN (invalid beam) are readings, not
    missing data (see [`scan_ranges`][mapping.features.scans.scan_ranges]), so scikit-learn's
    finiteness check is off and its ``allow_nan`` tag on.

    Examples
    --------
    >>> from mapping.features import ScanFeatures, ScanRangesInput
    >>> issubclass(ScanFeatures, ScanRangesInput)
    True
    >>> ScanFeatures().__sklearn_tags__().input_tags.allow_nan
    True

    See Also
    --------
    mapping.features.ScanFeatures, mapping.features.ScanStatistics : The transformers using it.
    mapping.features.scan_ranges : What the ranges' readings mean.
    """

    def __sklearn_tags__(self):
        """Return scikit-learn's tags, with NaN allowed in the input."""
        tags = super().__sklearn_tags__()
        tags.input_tags.allow_nan = True  # NaN (and inf) are readings: see scan_ranges
        return tags

    def _check_ranges(self, ranges: ArrayLike, reset: bool) -> np.ndarray:
        return validate_data(self, ranges, dtype=np.float64, ensure_all_finite=False, reset=reset)


class ScanFeatures(ScanRangesInput, TransformerMixin, BaseEstimator):
    """Laser scans -> feature vectors.

    A fit/transform wrapper of [`scan_vectors`][mapping.features.scans.scan_vectors].

    Parameters
    ----------
    max_range : float, optional
        Sensor range limit in metres. None takes the largest finite non-negative reading of
        the training scans (for sensors that report "no return" as their maximum range).
    representation : {"range", "inverse", "polar_grid"}, default "range"
    n_sectors : int, optional
    min_range : float, default 0.05
    n_range_bins : int, default 8
        See [`scan_vectors`][mapping.features.scans.scan_vectors].

    Attributes
    ----------
    n_features_in_ : int
        Beams per scan seen in ``fit``; ``transform`` requires the same.
    max_range_ : float
        The range limit used: ``max_range``, or the one found in the training scans.

    Examples
    --------
    >>> import numpy as np
    >>> from mapping.features import ScanFeatures
    >>> scans = np.array([[1.0, 2.0, np.inf, 4.0], [2.0, 2.0, 2.0, 2.0]])
    >>> features = ScanFeatures(max_range=5.0).fit(scans)
    >>> features.transform(scans).shape, features.max_range_
    ((2, 4), 5.0)

    See Also
    --------
    mapping.features.scan_vectors : The function this transformer wraps.
    mapping.features.ScanStatistics : Rotation-invariant statistics of the scans.
    mapping.grouping.ObservationGraphPartitioner : Groups scans by their overlap instead.
    """

    _parameter_constraints: dict = {
        "max_range": [Interval(Real, 0, None, closed="neither"), None],
        "representation": [StrOptions(set(SCAN_REPRESENTATIONS))],
        "n_sectors": [Interval(Integral, 1, None, closed="left"), None],
        "min_range": [Interval(Real, 0, None, closed="neither")],
        "n_range_bins": [Interval(Integral, 1, None, closed="left")],
    }

    def __init__(
        self,
        max_range: float | None = None,
        representation: str = "range",
        *,
        n_sectors: int | None = None,
        min_range: float = 0.05,
        n_range_bins: int = 8,
    ) -> None:
        self.max_range = max_range
        self.representation = representation
        self.n_sectors = n_sectors
        self.min_range = min_range
        self.n_range_bins = n_range_bins

    @_fit_context(prefer_skip_nested_validation=True)
    def fit(self, ranges: ArrayLike, y: None = None) -> ScanFeatures:
        """Record the number of beams and the range limit; check the parameters on the scans.

        Parameters
        ----------
        ranges : array-like of shape (n, n_beams)
            Training scans; inf = no return, NaN = invalid.
        y : None
            Ignored.

        Returns
        -------
        ScanFeatures
            This transformer, fitted.
        """
        r = self._check_ranges(ranges, reset=True)
        self.max_range_ = fitted_max_range(r, self.max_range)
        self._vectors(r)  # data-dependent checks (n_sectors, min_range) at fit time
        return self

    def _vectors(self, r: np.ndarray) -> np.ndarray:
        return scan_vectors(
            r,
            self.max_range_,
            self.representation,
            min_range=self.min_range,
            n_sectors=self.n_sectors,
            n_range_bins=self.n_range_bins,
        )

    def transform(self, ranges: ArrayLike) -> np.ndarray:
        """Return the feature vectors of the scans.

        Parameters
        ----------
        ranges : array-like of shape (n, n_beams)
            Scans; inf = no return, NaN = invalid.

        Returns
        -------
        ndarray of shape (n, D)
            One vector per scan (see [`scan_vectors`][mapping.features.scans.scan_vectors]).
        """
        check_is_fitted(self, "max_range_")
        return self._vectors(self._check_ranges(ranges, reset=False))
