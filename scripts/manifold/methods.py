"""The methods every manifold-clustering table compares, and how one fit is scored.

Ours with default settings, the two label-free baselines a user would pick
(`mapping.baselines.label_free`: scikit-learn's kNN-graph spectral clustering with its default
k and with k chosen by the eigengap; NCut with sigma chosen by the eigengap) and the paper's
best-sigma NCut, which chooses sigma on the labels it is scored on and is therefore only a
ceiling, never a competitor. Shared by ``scripts.manifold.protocol`` (datasets) and
``experiments.manifold.sweeps`` (synthetic sets).
"""

from __future__ import annotations

import warnings

import numpy as np

from mapping import ManifoldClustering, clustering_error
from mapping.baselines import EigengapNCutClustering, KNNSpectralClustering, best_sigma_ncut
from scripts.tables import Column, Table

OURS = "ours"
SKLEARN_DEFAULT = "scikit-learn kNN (k=10)"
SKLEARN_EIGENGAP = "scikit-learn kNN (eigengap k)"
NCUT_EIGENGAP = "NCut (eigengap sigma)"
NCUT_ORACLE = "NCut (label-chosen sigma, ceiling)"
METHODS = (OURS, SKLEARN_DEFAULT, SKLEARN_EIGENGAP, NCUT_EIGENGAP, NCUT_ORACLE)


def _fit(method: str, X: np.ndarray, y: np.ndarray | None, K: int, Q: int):
    """(fitted model with labels_ and predict, extra facts) of one method."""
    if method == OURS:
        model = ManifoldClustering(K, Q).fit(X)
        return model, {"leaves": int(model.leaf_labels_.max() + 1)}
    if method == SKLEARN_DEFAULT:
        return KNNSpectralClustering(K, 10).fit(X), {"k": 10}
    if method == SKLEARN_EIGENGAP:
        model = KNNSpectralClustering(K, "eigengap").fit(X)
        return model, {"k": model.n_neighbors_}
    if method == NCUT_EIGENGAP:
        model = EigengapNCutClustering(K).fit(X)
        return model, {"sigma": model.sigma_}
    if method == NCUT_ORACLE:
        if y is None:
            raise ValueError("the label-chosen NCut needs the training labels")
        sweep = best_sigma_ncut(X, y, K)
        return sweep.model, {"sigma": sweep.sigma}
    raise ValueError(f"unknown method {method!r}; expected one of {METHODS}")


def score_methods(
    X_train: np.ndarray,
    y_train: np.ndarray,
    K: int,
    Q: int,
    X_test: np.ndarray | None = None,
    y_test: np.ndarray | None = None,
    methods: tuple[str, ...] = METHODS,
) -> list[dict]:
    """Fit each method on ``X_train`` (labels only for the oracle) and score it.

    Errors are [`mapping.clustering_error`][mapping.metrics.clustering_error] (Hungarian
    matching of clusters to labels, as in the paper).

    Parameters
    ----------
    X_train : ndarray of shape (n, d)
        Training features.
    y_train : ndarray of shape (n,)
        Training labels: the fitted labels' error, and the oracle's choice of sigma.
    K : int
        Number of clusters.
    Q : int
        Minimum cluster size of ours.
    X_test : ndarray of shape (m, d), optional
        Test features, labelled by each model's ``predict``.
    y_test : ndarray of shape (m,), optional
        Test labels.
    methods : tuple of str, default METHODS
        The methods to fit, of ``METHODS``.

    Returns
    -------
    list of dict
        One per method: ``method``, ``train_error`` (clustering error of the fitted labels),
        ``test_error`` (of ``predict(X_test)``; None without a test set), ``seconds`` and the
        method's chosen scale or leaf count.
    """
    rows = []
    for method in methods:
        import time

        start = time.perf_counter()
        with warnings.catch_warnings():
            # scikit-learn warns when a kNN graph is disconnected; that is a result here
            warnings.filterwarnings("ignore", message="Graph is not fully connected")
            model, extra = _fit(method, X_train, y_train, K, Q)
            pred = None if X_test is None else model.predict(X_test)
        rows.append(
            {
                "method": method,
                "train_error": clustering_error(y_train, model.labels_),
                "test_error": None if pred is None else clustering_error(y_test, pred),
                "seconds": time.perf_counter() - start,
                **extra,
            }
        )
    return rows


def seed_error_row(errors, rng: np.random.Generator, **labels) -> dict:
    """Build a row of per-seed error rates: ``labels``, the ``errors`` and their bootstrap mean.

    Parameters
    ----------
    errors : iterable of float
        The error of each seed.
    rng : numpy.random.Generator
        Random numbers of the bootstrap.
    **labels
        The row's other cells (its group and method).

    Returns
    -------
    dict
        ``labels``, ``errors`` and ``summary`` (`bootstrap_mean`).
    """
    return {**labels, "errors": list(errors), "summary": bootstrap_mean(errors, rng)}


def seed_error_table(rows, group: Column, method_header: str, per_seed_header: str) -> Table:
    """Build a table of `seed_error_row` rows.

    Columns: the group, the method, the mean with its interval and the error of every seed
    (percent).

    Parameters
    ----------
    rows : list of dict
        Rows of `seed_error_row`.
    group : Column
        The column of the group.
    method_header : str
        Heading of the method column.
    per_seed_header : str
        Heading of the per-seed errors column.

    Returns
    -------
    Table
        The table.
    """

    def interval(s: dict) -> str:
        return f"{100 * s['mean']:.1f}% [{100 * s['lo']:.1f}, {100 * s['hi']:.1f}]"

    def percentages(errors) -> str:
        return ", ".join(f"{100 * e:.1f}" for e in errors)

    columns = (
        group,
        Column("method", method_header),
        Column("summary", "error: mean [95% CI]", interval),
        Column("errors", per_seed_header, percentages),
    )
    return Table.of(columns, rows)


def bootstrap_mean(values, rng: np.random.Generator, n_resamples: int = 4000) -> dict:
    """Return the mean of ``values`` with its bootstrap 95% percentile interval.

    The interval is ``scipy.stats.bootstrap``'s; with one value, or identical values, it is
    the value itself.

    Parameters
    ----------
    values : array-like of shape (n,)
        Finite numbers, at least one.
    rng : numpy.random.Generator
        Random numbers of the bootstrap.
    n_resamples : int, default 4000
        Bootstrap resamples.

    Returns
    -------
    dict
        ``mean``, ``lo``, ``hi`` and ``n``.

    Raises
    ------
    ValueError
        When ``values`` is not a non-empty 1-D list of finite numbers.
    """
    from scipy.stats import bootstrap

    x = np.asarray(values, dtype=np.float64)
    if x.ndim != 1 or x.size == 0 or not np.isfinite(x).all():
        raise ValueError(f"values must be a non-empty 1-D list of finite numbers, got {values!r}")
    mean = float(x.mean())
    if x.size == 1 or np.ptp(x) == 0:
        return {"mean": mean, "lo": mean, "hi": mean, "n": int(x.size)}
    res = bootstrap((x,), np.mean, n_resamples=n_resamples, method="percentile", random_state=rng)
    ci = res.confidence_interval
    return {"mean": mean, "lo": float(ci.low), "hi": float(ci.high), "n": int(x.size)}
