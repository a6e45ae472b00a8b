"""Laser-profile distances between the current scan and stored views' scans.

A scan's ranges along the corridor (the end wall, the junction) place the robot where image
features cannot. The profiles are compared over beam shifts, since a shift is a heading offset:
the best shift per view is the heading error toward it.
"""

from __future__ import annotations

import numpy as np

__all__ = ["PROFILE_SHIFT", "clip_ranges", "profile_distances"]

PROFILE_SHIFT = 70  # beams (35 deg at 0.5 deg per beam) tried as heading offsets


def clip_ranges(scans: np.ndarray, max_range: float) -> np.ndarray:
    """Return ranges with no return (inf, NaN) read as ``max_range``, for comparing profiles.

    Parameters
    ----------
    scans : ndarray
        Laser ranges, m (+inf or NaN: no return).
    max_range : float
        The laser's range, m; longer ranges are clipped to it.

    Returns
    -------
    ndarray
        The ranges, of the shape of ``scans``, finite and at most ``max_range``.
    """
    return np.nan_to_num(np.minimum(scans, max_range), nan=max_range, posinf=max_range)


def profile_distances(
    table: np.ndarray, ranges: np.ndarray, beam_step: float, max_shift: int = PROFILE_SHIFT
) -> tuple[np.ndarray, np.ndarray]:
    """Return the laser-profile distance of the current scan to each stored view, over shifts.

    The distance is the mean range difference of the current clipped ``ranges`` to each clipped
    stored profile in ``table``, minimised over beam shifts of up to ``max_shift`` beams (every
    5th); the heading of the best shift per view comes with it.

    Parameters
    ----------
    table : ndarray of shape (n, B)
        The stored views' clipped ranges ([`clip_ranges`][servo.maps.scan_profile.clip_ranges]).
    ranges : ndarray of shape (B,)
        The current scan's clipped ranges.
    beam_step : float
        Angle between neighbouring beams, rad.
    max_shift : int, default PROFILE_SHIFT
        Largest shift tried each way, beams.

    Returns
    -------
    distances : ndarray of shape (n,)
        The smallest mean range difference per view, m.
    headings : ndarray of shape (n,)
        The heading of the best shift per view, rad (``shift * beam_step``).

    Raises
    ------
    ValueError
        When the scan has no more than ``max_shift`` beams.
    """
    n = len(ranges)
    if n <= max_shift:  # a shift would leave nothing to compare (servo.maps.needs: MIN_BEAMS)
        raise ValueError(f"a scan of {n} beams cannot be shifted by up to {max_shift} beams")
    best = np.full(len(table), np.inf)
    yaw = np.zeros(len(table))
    for s in range(-max_shift, max_shift + 1, 5):
        cur = ranges[max(0, -s) : n - max(0, s)]
        ref = table[:, max(0, s) : n - max(0, -s)]
        d = np.abs(ref - cur).mean(axis=1)
        better = d < best
        best[better], yaw[better] = d[better], s * beam_step
    return best, yaw
