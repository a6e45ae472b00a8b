"""Recordings as runs: where each drive of a sequence of samples begins.

Scan matching, local maps, the pose graph and the topological map all chain consecutive
samples of one drive and never across two; this is where a run begins.
"""

from __future__ import annotations

from collections import Counter

import numpy as np
from numpy.typing import ArrayLike

__all__ = ["run_starts_from_groups"]


def run_starts_from_groups(groups: ArrayLike | None, n: int) -> np.ndarray:
    """Mark where each run begins, from ``groups``, the run (drive) of each of ``n`` samples.

    ``groups`` follows scikit-learn's convention for a per-sample grouping (as in
    ``GroupKFold``): one label per sample, any hashable values. Samples of one run must be
    consecutive (they are one drive in time order); a run starts wherever the label changes.
    ``None`` is one run.

    Parameters
    ----------
    groups : array-like of shape (n,) or None
        The run of each sample.
    n : int
        Number of samples.

    Returns
    -------
    ndarray of shape (n,), bool
        True where a run begins; index 0 always does.

    Raises
    ------
    ValueError
        Naming ``groups``: not one label per sample, a missing (NaN) label, or a run whose
        samples are not consecutive.
    """
    starts = np.zeros(n, dtype=bool)
    if n:
        starts[0] = True
    if groups is None:
        return starts
    groups = np.asarray(groups)
    if groups.shape != (n,):
        raise ValueError(f"groups must have one label per sample, shape ({n},), got {groups.shape}")
    missing = np.isnan(groups) if groups.dtype.kind == "f" else None
    if groups.dtype == object:  # Python objects: None, or float NaN among other labels
        missing = np.array([g is None or (isinstance(g, float) and g != g) for g in groups])
    if missing is not None and missing.any():
        raise ValueError(
            f"groups contains {groups[missing][0]} (a missing label); give every sample the "
            "label of its run"
        )
    starts[1:] = groups[1:] != groups[:-1]
    repeated = _repeated(groups[starts])
    if repeated:
        raise ValueError(
            f"groups must keep each run's samples consecutive; label(s) {repeated[:5]} occur "
            "in separate stretches"
        )
    return starts


def _repeated(values: np.ndarray) -> list:
    """Return the values that occur more than once.

    Found by hashing, so that labels numpy cannot sort (ints mixed with strings in an object
    array) work too.
    """
    return [v for v, count in Counter(values.tolist()).items() if count > 1]
