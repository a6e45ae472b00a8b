"""Laser scans as sector and ring statistics.

`mapping.features` turns a scan into its ranges, inverse ranges or a polar occupancy grid:
one number per beam or per (sector, range bin). Those vectors change a lot when the robot turns
a few degrees or a single beam misses, and they weigh every beam alike. The statistics here
summarise a scan the way a person reads a corridor:

* per angular **sector** (a run of consecutive beams): the ``mean``, ``min`` and ``std`` of the
  range (over ``max_range``), the fraction of beams with ``no_return``, and the mean
  ``inverse`` range (``min_range / r``, which stresses near walls);
* a **ring** occupancy histogram (``rings``): the fraction of all beams whose return falls in
  each range ring, rings spaced geometrically from ``min_range`` to ``max_range`` (near rings
  thin, far rings wide, as range error and relevance both scale with range). It ignores the
  beam order, so it does not change when the robot turns: the rotation-tolerant block.

Each statistic is one *block*. [`ScanStatistics`][mapping.features.statistics.ScanStatistics]
learns, per block, the total standard deviation of the training scans and divides by it, so every
block enters a Euclidean distance (all the clustering methods here use one) with the same weight,
whatever its units or its number of sectors.
"""

from __future__ import annotations

from numbers import Integral, Real

import numpy as np
from numpy.typing import ArrayLike
from sklearn.base import BaseEstimator, TransformerMixin, _fit_context
from sklearn.utils._param_validation import Interval
from sklearn.utils.validation import check_is_fitted

from mapping.features.scans import ScanRangesInput, fitted_max_range, scan_ranges

__all__ = ["SCAN_STATISTICS", "ScanStatistics", "scan_statistics"]

SECTOR_STATISTICS = ("mean", "min", "std", "no_return", "inverse")
SCAN_STATISTICS = (*SECTOR_STATISTICS, "rings")


def _check_statistics(statistics) -> tuple[str, ...]:
    if isinstance(statistics, str):
        statistics = (statistics,)
    stats = tuple(statistics)
    unknown = [s for s in stats if s not in SCAN_STATISTICS]
    if not stats or unknown or len(set(stats)) != len(stats):
        raise ValueError(
            f"statistics must be a non-empty list of distinct names from {SCAN_STATISTICS}, "
            f"got {statistics!r}"
        )
    return stats


def scan_statistics(
    ranges: ArrayLike,
    max_range: float,
    statistics=SCAN_STATISTICS,
    *,
    n_sectors: int = 12,
    n_rings: int = 8,
    min_range: float = 0.25,
) -> list[np.ndarray]:
    """Return the blocks of sector and ring statistics of scans, unscaled.

    Parameters
    ----------
    ranges : array-like of shape (n_beams,) or (n, n_beams)
        Raw ranges; ``+inf`` = no return, NaN or negative = invalid (both read as "nothing
        seen", see [`mapping.features.scan_ranges`][mapping.features.scans.scan_ranges]). Beams are
        ordered by angle.
    max_range : float
        Sensor range limit in metres.
    statistics : sequence of str, default all of ``SCAN_STATISTICS``
        Which blocks, in this order (see the module docstring).
    n_sectors : int, default 12
        Equal runs of consecutive beams (as even as ``np.array_split``) for the sector blocks.
    n_rings : int, default 8
        Rings of the ``rings`` histogram.
    min_range : float, default 0.25
        Inner edge of the first ring, and the floor of the ranges for ``inverse``.

    Returns
    -------
    list of ndarray
        One (n, width) float64 array per statistic: ``n_sectors`` columns for a sector
        statistic, ``n_rings`` for ``rings``.
    """
    stats = _check_statistics(statistics)
    r = scan_ranges(ranges, max_range)
    n_beams = r.shape[1]
    if isinstance(n_sectors, bool) or not isinstance(n_sectors, Integral):
        raise ValueError(f"n_sectors must be an integer, got {n_sectors!r}")
    # sectors need beams to pool; the ring block alone pools all beams and takes any count
    if not 1 <= n_sectors <= n_beams and set(stats) != {"rings"}:
        raise ValueError(f"n_sectors must be in [1, n_beams={n_beams}], got {n_sectors!r}")
    if isinstance(n_rings, bool) or not isinstance(n_rings, Integral) or n_rings < 1:
        raise ValueError(f"n_rings must be a positive integer, got {n_rings!r}")
    if not 0 < min_range < max_range:
        raise ValueError(f"min_range must be in (0, max_range={max_range}), got {min_range!r}")

    # Sector sums with one reduceat each: mean, and std from E[r^2] - E[r]^2.
    starts = np.linspace(0, n_beams, n_sectors + 1).astype(int)
    counts = np.diff(starts).astype(np.float64)
    u = r / max_range

    def sector_mean(values: np.ndarray) -> np.ndarray:
        return np.add.reduceat(values, starts[:-1], axis=1) / counts

    blocks = {}
    for name in stats:
        if name == "mean":
            blocks[name] = sector_mean(u)
        elif name == "min":
            blocks[name] = np.minimum.reduceat(u, starts[:-1], axis=1)
        elif name == "std":
            m = sector_mean(u)
            blocks[name] = np.sqrt(np.maximum(sector_mean(u * u) - m * m, 0.0))
        elif name == "no_return":
            blocks[name] = sector_mean((r >= max_range).astype(np.float64))
        elif name == "inverse":
            blocks[name] = sector_mean(min_range / np.maximum(r, min_range))
        else:  # rings
            edges = np.geomspace(min_range, max_range, n_rings + 1)
            # ring k holds returns in [edges[k], edges[k+1]); nearer than min_range joins ring 0
            ring = np.clip(np.searchsorted(edges, r, side="right") - 1, 0, n_rings - 1)
            hit = r < max_range
            rows = np.broadcast_to(np.arange(len(r))[:, None], r.shape)
            hist = np.zeros((len(r), n_rings))
            np.add.at(hist, (rows[hit], ring[hit]), 1.0)
            blocks[name] = hist / n_beams
    return [blocks[name] for name in stats]


class ScanStatistics(ScanRangesInput, TransformerMixin, BaseEstimator):
    """Laser scans -> sector and ring statistics, each block scaled to unit total spread.

    Parameters
    ----------
    max_range : float, optional
        Sensor range limit in metres. None takes the largest finite positive reading of the
        training scans (as [`mapping.ScanFeatures`][mapping.features.scans.ScanFeatures] does).
    statistics : tuple of str, default all of ``SCAN_STATISTICS``
        The blocks (see [`scan_statistics`][mapping.features.statistics.scan_statistics]).
    n_sectors : int, default 12
    n_rings : int, default 8
    min_range : float, default 0.25
        See [`scan_statistics`][mapping.features.statistics.scan_statistics].
    block_scaling : bool, default True
        Divide each block by its training scans' total standard deviation
        (``sqrt`` of the sum of its columns' variances), so that every block weighs the same in
        a Euclidean distance. A block that does not vary is left as it is.

    Attributes
    ----------
    n_features_in_ : int
        Beams per scan seen in ``fit``.
    max_range_ : float
        The range limit used.
    block_scales_ : ndarray of shape (n_blocks,)
        The divisor of each block (1 without ``block_scaling``).

    Examples
    --------
    >>> import numpy as np
    >>> from mapping.features import ScanStatistics
    >>> angles = np.linspace(-np.pi / 2, np.pi / 2, 181)
    >>> scans = np.stack([2.0 + np.sin(k * angles) ** 2 for k in range(1, 6)])
    >>> features = ScanStatistics(max_range=10.0).fit(scans)
    >>> features.transform(scans).shape[0], len(features.block_scales_)
    (5, 6)

    See Also
    --------
    mapping.features.scan_statistics : The blocks, unscaled.
    mapping.features.ScanFeatures : The ranges themselves as features.
    """

    _parameter_constraints: dict = {
        "max_range": [Interval(Real, 0, None, closed="neither"), None],
        "statistics": [tuple, list, str],
        "n_sectors": [Interval(Integral, 1, None, closed="left")],
        "n_rings": [Interval(Integral, 1, None, closed="left")],
        "min_range": [Interval(Real, 0, None, closed="neither")],
        "block_scaling": ["boolean"],
    }

    def __init__(
        self,
        max_range: float | None = None,
        statistics=SCAN_STATISTICS,
        *,
        n_sectors: int = 12,
        n_rings: int = 8,
        min_range: float = 0.25,
        block_scaling: bool = True,
    ) -> None:
        self.max_range = max_range
        self.statistics = statistics
        self.n_sectors = n_sectors
        self.n_rings = n_rings
        self.min_range = min_range
        self.block_scaling = block_scaling

    def _blocks(self, r: np.ndarray) -> list[np.ndarray]:
        return scan_statistics(
            r,
            self.max_range_,
            self.statistics,
            n_sectors=self.n_sectors,
            n_rings=self.n_rings,
            min_range=self.min_range,
        )

    @_fit_context(prefer_skip_nested_validation=True)
    def fit(self, ranges: ArrayLike, y: None = None) -> ScanStatistics:
        """Learn the range limit (if not given) and each block's scale from training scans.

        Parameters
        ----------
        ranges : array-like of shape (n, n_beams)
            Training scans; inf = no return, NaN = invalid.
        y : None
            Ignored.

        Returns
        -------
        ScanStatistics
            This transformer, fitted.
        """
        r = self._check_ranges(ranges, reset=True)
        self.max_range_ = fitted_max_range(r, self.max_range)
        blocks = self._blocks(r)
        scales = np.ones(len(blocks))
        if self.block_scaling:
            spread = np.array([np.sqrt(b.var(axis=0).sum()) for b in blocks])
            # a constant block (or a single scan) has nothing to scale by: keep its units
            scales = np.where(spread > 1e-12, spread, 1.0)
        self.block_scales_ = scales
        return self

    def transform(self, ranges: ArrayLike) -> np.ndarray:
        """Return the scaled feature vectors of the scans.

        Parameters
        ----------
        ranges : array-like of shape (n, n_beams)
            Scans; inf = no return, NaN = invalid.

        Returns
        -------
        ndarray of shape (n, n_sectors * sector blocks + n_rings * ring block)
            The blocks side by side, each divided by its ``block_scales_`` entry.
        """
        check_is_fitted(self, "block_scales_")
        blocks = self._blocks(self._check_ranges(ranges, reset=False))
        return np.hstack([b / s for b, s in zip(blocks, self.block_scales_, strict=True)])
