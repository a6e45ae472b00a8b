"""Clustering scores that compare a predicted labelling with the true one.

All scores are invariant to renaming the labels, accept any hashable label values that numpy can
sort (integers, strings) and allow the two labellings to have different numbers of clusters.

``clustering_error`` is the score the paper reports (Grudic & Mulligan, Section III, citing
Verma & Meila [16]): the fraction of points misassigned under the best one-to-one matching of
predicted clusters to true classes. The contingency matrix and the adjusted Rand index are
scikit-learn's (``sklearn.metrics.cluster``), behind this module's shared input checks.
"""

from __future__ import annotations

import numpy as np
from numpy.typing import ArrayLike
from scipy.optimize import linear_sum_assignment
from sklearn.metrics import adjusted_rand_score
from sklearn.metrics.cluster import contingency_matrix as _sk_contingency_matrix

__all__ = [
    "adjusted_rand_index",
    "best_matching",
    "clustering_error",
    "contingency_matrix",
    "majority_merge_error",
    "purity",
]


def check_labels(y: ArrayLike, name: str) -> np.ndarray:
    """Return ``y`` as a 1-D array of labels, refusing a missing (NaN, None) or infinite one.

    A NaN would otherwise be one more class (NaN labels all compare unequal, yet
    scikit-learn's contingency counts them together) and None cannot be sorted with the other
    labels; both usually mean "no ground truth here": drop those points before scoring.

    Parameters
    ----------
    y : array-like of shape (n,)
        Labels.
    name : str
        Its name, for the error messages.

    Returns
    -------
    ndarray of shape (n,)
        The labels.
    """
    y = np.asarray(y)
    if y.ndim != 1:
        raise ValueError(f"{name} must be 1-D, got shape {y.shape}")
    if y.dtype.kind in "fc":
        bad = ~np.isfinite(y)
    elif y.dtype.kind == "O":  # Python objects: None, or float NaN among other labels
        bad = np.array(
            [v is None or (isinstance(v, float | np.floating) and not np.isfinite(v)) for v in y]
        )
    else:
        return y
    if bad.any():
        raise ValueError(
            f"{name} must hold a finite label for every point, got {y[bad][0]} at index "
            f"{int(np.argmax(bad))} (drop unlabelled points, or give them a label of their own)"
        )
    return y


def _check_labellings(y_true: ArrayLike, y_pred: ArrayLike) -> tuple[np.ndarray, np.ndarray]:
    """Return both labellings as 1-D arrays after checking they describe the same points."""
    y_true = check_labels(y_true, "y_true")
    y_pred = check_labels(y_pred, "y_pred")
    if y_true.shape[0] != y_pred.shape[0]:
        raise ValueError(
            f"y_true and y_pred must have the same length, got {y_true.shape[0]} "
            f"and {y_pred.shape[0]}"
        )
    if y_true.shape[0] == 0:
        raise ValueError("y_true and y_pred are empty; need at least one labelled point")
    return y_true, y_pred


def contingency_matrix(y_true: ArrayLike, y_pred: ArrayLike) -> np.ndarray:
    """Count the points of each (true class, predicted cluster) pair.

    Parameters
    ----------
    y_true, y_pred : array-like of shape (n,)
        Two labellings of the same points; label values are arbitrary.

    Returns
    -------
    ndarray of shape (n_classes, n_clusters), int64
        ``C[i, j]`` is the number of points of the i-th true class (in sorted label order) that
        were put in the j-th predicted cluster.
    """
    y_true, y_pred = _check_labellings(y_true, y_pred)
    return _sk_contingency_matrix(y_true, y_pred, dtype=np.int64)


def clustering_error(y_true: ArrayLike, y_pred: ArrayLike) -> float:
    """Fraction of points misassigned under the best one-to-one label matching.

    Each predicted cluster is matched to at most one true class (and vice versa) so that the
    number of correctly labelled points is maximal (Hungarian algorithm on the contingency
    matrix). Points in predicted clusters left unmatched -- there are more clusters than classes
    -- count as errors, as do points of classes left without a cluster. This is the clustering
    error of Verma & Meila [16] used throughout Section III of the paper.

    Parameters
    ----------
    y_true, y_pred : array-like of shape (n,)
        True and predicted labels; any values, any number of distinct values.

    Returns
    -------
    float
        Error in [0, 1); 0 means the two partitions are identical up to renaming.

    Raises
    ------
    ValueError
        If the labellings are not 1-D, are empty, differ in length, or miss a label (NaN,
        None) or hold an infinite one.

    Examples
    --------
    >>> from mapping import clustering_error
    >>> clustering_error([0, 0, 1, 1], ["b", "b", "a", "a"])
    0.0
    >>> clustering_error([0, 0, 0, 0], [0, 0, 1, 2])
    0.5
    """
    counts, rows, cols = _hungarian(y_true, y_pred)
    matched = int(counts[rows, cols].sum())
    n = int(counts.sum())
    return float(n - matched) / n


def _hungarian(y_true: ArrayLike, y_pred: ArrayLike):
    """Return the contingency matrix and the (class rows, cluster columns) of the best match."""
    counts = contingency_matrix(y_true, y_pred)
    rows, cols = linear_sum_assignment(counts, maximize=True)
    return counts, rows, cols


def best_matching(y_true: ArrayLike, y_pred: ArrayLike) -> dict:
    """Return the matching [`clustering_error`][mapping.metrics.clustering_error] scores.

    Clusters left unmatched (more clusters than classes) are absent from the dict.

    Parameters
    ----------
    y_true, y_pred : array-like of shape (n,)
        True and predicted labels.

    Returns
    -------
    dict
        Predicted cluster -> its true class, in the best one-to-one match.
    """
    _, rows, cols = _hungarian(y_true, y_pred)  # checks both labellings
    classes, clusters = np.unique(np.asarray(y_true)), np.unique(np.asarray(y_pred))
    return {clusters[j].item(): classes[i].item() for i, j in zip(rows, cols, strict=True)}


def purity(y_true: ArrayLike, y_pred: ArrayLike) -> float:
    """Fraction of points whose predicted cluster's majority class is their own class.

    Unlike [`clustering_error`][mapping.metrics.clustering_error] several clusters may share a
    majority class, so purity rewards over-segmentation (every point in its own cluster gives purity
    1).

    Parameters
    ----------
    y_true, y_pred : array-like of shape (n,)
        True and predicted labels.

    Returns
    -------
    float
        Purity in (0, 1].
    """
    counts = contingency_matrix(y_true, y_pred)
    return float(counts.max(axis=0).sum()) / float(counts.sum())


def adjusted_rand_index(y_true: ArrayLike, y_pred: ArrayLike) -> float:
    """Return the Rand index adjusted for chance (Hubert & Arabie, 1985).

    It is scikit-learn's ``adjusted_rand_score`` after this module's input checks (1-D, same
    length, not empty).

    Two identical trivial partitions (a single cluster, or all singletons) score 1.

    Parameters
    ----------
    y_true, y_pred : array-like of shape (n,)
        True and predicted labels.

    Returns
    -------
    float
        1 for identical partitions, about 0 for independent ones, possibly negative.
    """
    y_true, y_pred = _check_labellings(y_true, y_pred)
    return float(adjusted_rand_score(y_true, y_pred))


def majority_merge_error(y_true: ArrayLike, leaves: ArrayLike) -> float:
    """Clustering error when each leaf takes its majority true label.

    The best any combination of the leaves into clusters can do: a lower bound on the error
    of every rule that combines a clustering's leaves (the C clusters of Grudic & Mulligan's
    Section II-E before they are combined into K).

    Parameters
    ----------
    y_true : array-like of shape (n,)
        True labels.
    leaves : array-like of shape (n,)
        The leaf of each sample.

    Returns
    -------
    float
        In [0, 1].
    """
    y_true, leaves = _check_labellings(y_true, leaves)
    values, y_index = np.unique(y_true, return_inverse=True)
    merged = np.empty_like(y_true)
    for leaf in np.unique(leaves):
        members = leaves == leaf
        merged[members] = values[np.bincount(y_index[members]).argmax()]
    return clustering_error(y_true, merged)
