"""Checks of a fitted state read from a file, and of training points.

The checks of a fitted state read back from a file (`check_layout`, `check_number`) and the
checks of training points every clustering shares (`check_span`, `check_distinct_rows`).

Input and parameter checks are scikit-learn's (``validate_data``, ``_parameter_constraints``,
``check_is_fitted``); only what scikit-learn does not do lives here.
"""

from __future__ import annotations

import numpy as np

# The span of X (largest range of a feature) that float64 distances can hold: a kernel width is
# a fraction of it, and sigma^2 and the squared distances must stay normal numbers.
SPAN_RANGE = (1e-140, 1e140)


def is_plain_query(estimator, X, bound: float = np.inf) -> bool:
    """Check whether X is already what ``validate_data(estimator, X, reset=False)`` would return.

    True for a C-contiguous, finite, non-empty float32/float64 ndarray of shape
    (k, n_features_in_) whose sum of squares is at most ``bound^2``, when the estimator was
    fitted without feature names. Checking this
    directly costs microseconds where ``validate_data`` costs ~0.2 ms, as much as the whole
    eq. 13 solve for one view; anything else must go through ``validate_data``.

    Parameters
    ----------
    estimator : object
        The fitted estimator, with its ``n_features_in_``.
    X : object
        The query.
    bound : float, default inf
        Largest Euclidean norm of X taken as plain.

    Returns
    -------
    bool
        True when X needs no ``validate_data``.
    """
    if not (
        type(X) is np.ndarray
        and X.ndim == 2
        and X.dtype in (np.float64, np.float32)
        and X.shape[0] > 0
        and X.shape[1] == getattr(estimator, "n_features_in_", -1)
        and X.flags.c_contiguous
        and not hasattr(estimator, "feature_names_in_")
    ):
        return False
    # a NaN or inf makes the sum of squares NaN or inf (so does an overflow, which then goes
    # through validate_data): a quarter of np.isfinite(X).all()'s time. Below bound^2 every
    # value lies within ``bound`` (above it, the caller checks the values themselves).
    with np.errstate(over="ignore", invalid="ignore"):
        return bool(X.ravel() @ X.ravel() <= bound * bound)


def check_layout(record, layout: dict[str, tuple[str, ...]]) -> dict[str, int]:
    """Check a record's array fields against symbolic shapes and return the sizes.

    ``layout`` maps a field name to its dimensions by symbol (``("m", "d")``); a symbol takes
    the size of its first occurrence, and every other occurrence must match it. Every array
    must be numeric and finite; a field named ``indices`` must be of an integer dtype and
    non-negative. Raises ValueError naming the field and the expected form (what a file saved
    by `mapping.persistence` and then altered gets).

    Parameters
    ----------
    record : object
        The record whose array fields are checked (read as attributes).
    layout : dict of str to tuple of str
        Field name -> its dimensions by symbol.

    Returns
    -------
    dict of str to int
        Size of each symbol.
    """
    sizes: dict[str, int] = {}
    for name, dims in layout.items():
        a = getattr(record, name)
        form = f"({', '.join(dims)})"
        if not (isinstance(a, np.ndarray) and a.ndim == len(dims) and a.dtype.kind in "biuf"):
            raise ValueError(f"{name} must be a numeric array of shape {form}")
        for sym, n in zip(dims, a.shape, strict=True):
            if sizes.setdefault(sym, n) != n:
                raise ValueError(
                    f"{name} has shape {a.shape}, not {form} with {sym} = {sizes[sym]} "
                    "as in the other fields"
                )
        if name == "indices":
            if a.dtype.kind not in "iu" or (a.size and a.min() < 0):
                raise ValueError(f"{name} must hold non-negative integers")
        elif not np.isfinite(a).all():
            raise ValueError(f"{name} must be finite")
    return sizes


def check_number(value, name: str, low: float, high: float, integer: bool = False) -> None:
    """Check ``low <= value <= high`` for a real number (an int if ``integer``; never a bool).

    Parameters
    ----------
    value : object
        The value to check.
    name : str
        Its name, for the error message.
    low, high : float
        The bounds, both included.
    integer : bool, default False
        Require an integer.

    Raises
    ------
    ValueError
        If ``value`` is not such a number.
    """
    kinds = (int, np.integer) if integer else (int, float, np.integer, np.floating)
    if isinstance(value, bool) or not isinstance(value, kinds) or not low <= value <= high:
        kind = "an integer" if integer else "a number"
        raise ValueError(f"{name} must be {kind} in [{low}, {high}], got {value!r}")


def check_span(X: np.ndarray) -> float:
    """Return the span of the training points X (the largest range of a feature), checked.

    Raises ValueError naming X when the samples span more than float64 squared distances can
    hold (or less than a normal number's square root): at 1e200 the distances overflow to inf,
    at 1e-200 they underflow to 0 and every sample looks identical. Identical samples (span 0)
    pass: each estimator says in its own words that there is nothing to cluster.

    Parameters
    ----------
    X : ndarray of shape (n, d)
        Training points.

    Returns
    -------
    float
        The largest ``max - min`` over the features (inf when it overflows).
    """
    with np.errstate(over="ignore"):  # an overflowing span is inf, refused below
        spread = float(np.ptp(X, axis=0).max())
    if spread > 0 and not SPAN_RANGE[0] <= spread <= SPAN_RANGE[1]:
        raise ValueError(
            f"X: the samples span {spread:.3g}; squared distances and sigma^2 must be normal "
            f"float64 numbers, so the span must lie in [{SPAN_RANGE[0]:g}, {SPAN_RANGE[1]:g}]: "
            "rescale X (the clustering does not depend on its scale)"
        )
    return spread


def _projected_count(X: np.ndarray) -> int:
    """Count the distinct values of one projection of the rows of X.

    Never more than the distinct rows (copies project alike), and as many on every ordinary
    data set.
    """
    # a fixed projection with unequal weights, so that rows with permuted coordinates differ
    with np.errstate(over="ignore", invalid="ignore"):
        return int(np.unique(X @ np.linspace(1.0, 2.0, X.shape[1])).size)


def first_copies(X: np.ndarray) -> np.ndarray | None:
    """Return the index of the first copy of each distinct row of X, ascending.

    None when no two rows are equal (found without sorting the rows when a projection already
    tells them apart).

    Parameters
    ----------
    X : ndarray of shape (n, d)
        The rows.

    Returns
    -------
    ndarray of int or None
        The first copies, or None when every row is distinct.
    """
    if _projected_count(X) == X.shape[0]:
        return None
    _, first = np.unique(X, axis=0, return_index=True)
    return None if first.size == X.shape[0] else np.sort(first)


def check_distinct_rows(X: np.ndarray, n_clusters: int) -> None:
    """Refuse fewer distinct rows in X than ``n_clusters``.

    Identical samples cannot be told apart, so a clustering would split copies of one point
    into different clusters (or its eigensolver fail). The rows are sorted only when a
    projection has fewer distinct values.

    Parameters
    ----------
    X : ndarray of shape (n, d)
        Training points.
    n_clusters : int
        Number of clusters asked for.

    Raises
    ------
    ValueError
        If X has fewer than ``n_clusters`` distinct rows.
    """
    if n_clusters <= 1 or _projected_count(X) >= n_clusters:
        return
    n_distinct = np.unique(X, axis=0).shape[0]
    if n_distinct < n_clusters:
        raise ValueError(
            f"n_clusters={n_clusters} needs at least {n_clusters} distinct samples in X; "
            f"it has {n_distinct} groups of identical samples"
        )
