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
    """Ranges with no return (inf, NaN) read as ``max_range``, for comparing profiles."""
    return np.nan_to_num(np.minimum(scans, max_range), nan=max_range, posinf=max_range)


def profile_distances(
    table: np.ndarray, ranges: np.ndarray, beam_step: float, max_shift: int = PROFILE_SHIFT
) -> tuple[np.ndarray, np.ndarray]:
    """Mean range difference of the current clipped ``ranges`` (B,) to each clipped stored
    profile in ``table`` (n, B), minimised over beam shifts of up to ``max_shift`` beams (every
    5th), and the heading (rad, ``shift * beam_step``) of the best shift per view.
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
