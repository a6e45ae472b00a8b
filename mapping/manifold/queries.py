"""New views on a fitted ManifoldClustering: eq. 13 (Section II-F/G).

The estimator is [`ManifoldClustering`][mapping.manifold.clustering.ManifoldClustering].

``predict`` and ``predict_proba`` assign views by ``argmax_j F^j(k)``; ``signal`` and
``signals`` give F^j(k) toward a stored view, the signal a robot servoes by. The per-cluster
models they read (``_models``, built in ``fit``) are in `mapping.manifold.cluster_model`
(dense path) and `mapping.manifold.graph_cluster_model` (k-NN graph path).
"""

from __future__ import annotations

from numbers import Integral

import numpy as np
from numpy.typing import ArrayLike
from sklearn.utils.validation import check_is_fitted, validate_data

from mapping.manifold.graph_cluster_model import GraphClusterModel, model_scores
from mapping.manifold.stacked_signal import Stack
from mapping.validation import is_plain_query

# The largest query value whose distances to the stored points stay finite: float64 squares
# up to 1e300; float32 products of a query and a stored point (both up to 1e15, the training
# span float32 storage is used for) summed over d features stay below 3.4e38.
_QUERY_BOUND = {np.dtype(np.float64): 1e150, np.dtype(np.float32): 1e15}


class ManifoldQueries:
    """Eq. 13 on new views, for an estimator whose ``fit`` set its clusters' state.

    That state is ``labels_``, ``centers_`` and one cluster model per cluster in ``_models``.
    """

    def _check_fitted_state(self) -> None:
        """Check the state the queries read is as ``fit`` leaves it.

        For an estimator read from a file (`mapping.persistence`): labels, centres, per-cluster
        sigma and alpha, and one valid cluster model per cluster on the points of its label.
        Raises ValueError.
        """
        labels, models = getattr(self, "labels_", None), getattr(self, "_models", None)
        if not (
            isinstance(labels, np.ndarray)
            and labels.ndim == 1
            and labels.size
            and labels.dtype.kind in "iu"
        ):
            raise ValueError("labels_ must be a non-empty 1-D integer array")
        if not (isinstance(models, list) and models and len({type(m) for m in models}) == 1):
            raise ValueError("_models must be a non-empty list of cluster models of one class")
        n, K = labels.shape[0], len(models)
        if labels.min() < 0 or labels.max() >= K:
            raise ValueError(f"labels_ must lie in [0, {K}), one per cluster model")
        for name in ("centers_", "sigmas_", "alphas_"):
            value = getattr(self, name, None)
            if not (isinstance(value, np.ndarray) and value.shape == (K,)):
                raise ValueError(f"{name} must be an array of shape ({K},)")
        d = getattr(self, "n_features_in_", None)
        for j, model in enumerate(models):
            try:
                sizes = model.validate()
            except ValueError as err:
                raise ValueError(f"_models[{j}]: {err}") from err
            if sizes["d"] != d:
                raise ValueError(f"_models[{j}] has {sizes['d']} features, not n_features_in_ {d}")
            idx = model.indices
            if idx.max(initial=-1) >= n or not np.all(labels[idx] == j):
                raise ValueError(f"_models[{j}].indices must be the training points of label {j}")
            if idx[model.centre] != self.centers_[j]:
                raise ValueError(f"centers_[{j}] must be _models[{j}]'s centre")

    def _check_query(self, X: ArrayLike) -> np.ndarray:
        """Check new points: fitted, then finite 2-D float with the feature count of ``fit``."""
        check_is_fitted(self, "labels_")
        bound = _QUERY_BOUND[self._store_dtype()]
        if is_plain_query(self, X, bound):
            return X
        X = validate_data(self, X, dtype=[np.float64, np.float32], order="C", reset=False)
        largest = float(np.abs(X).max())
        if largest > bound:
            raise ValueError(
                f"X: values up to {largest:.3g}; distances to the stored points can be computed "
                f"for values up to {bound:g}"
                + (" (fit with store_dtype='float64' for more)" if bound < 1e100 else "")
            )
        return X

    def _store_dtype(self) -> np.dtype:
        """Return the dtype the cluster models keep their points in (``store_dtype`` or float64)."""
        model = self._models[0]
        return (model.basis if hasattr(model, "basis") else model.points).dtype

    # ------------------------------------------------------------------ predict
    def _scores(self, X: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Return comparable F^j(k) for every row and cluster, and the fallback scaled distances."""
        normalize = self.normalize == "column"
        if any(isinstance(m, GraphClusterModel) for m in self._models):
            return model_scores(self._models, X, normalize)
        return Stack.of(self._models).scores(X, normalize)

    def predict(self, X: ArrayLike) -> np.ndarray:
        """Assign new points by eq. 13: ``y = argmax_j F^j(k)``.

        A point too far from every cluster for any affinity to be representable (all F^j are
        exactly 0) goes to the cluster with the smallest ``min_i |x - x_i|^2 / (2 sigma_j^2)``,
        the exponent that underflowed.

        Parameters
        ----------
        X : array-like of shape (k, d)
            New points.

        Returns
        -------
        ndarray of shape (k,)
            Cluster of each point.
        """
        scores, nearest = self._scores(self._check_query(X))
        labels = np.argmax(scores, axis=1)
        lost = ~(scores.max(axis=1) > 0)
        labels[lost] = np.argmin(nearest[lost], axis=1)
        return labels

    def predict_proba(self, X: ArrayLike) -> np.ndarray:
        """Probability that each point lies on each cluster's manifold.

        The normalised F^j(k) of `predict` divided by their sum over clusters, so rows sum
        to 1 and the argmax is ``predict``. Rows where every F^j is 0 are one-hot on the
        fallback cluster of `predict`.

        Parameters
        ----------
        X : array-like of shape (k, d)
            New points.

        Returns
        -------
        ndarray of shape (k, K)
            Probability of each point and cluster.
        """
        scores, nearest = self._scores(self._check_query(X))
        total = scores.sum(axis=1, keepdims=True)
        proba = np.zeros_like(scores)
        found = total[:, 0] > 0
        proba[found] = scores[found] / total[found]
        lost = np.flatnonzero(~found)
        proba[lost, np.argmin(nearest[lost], axis=1)] = 1.0
        return proba

    def signal(self, X: ArrayLike, cluster: int, target: int | None = None) -> np.ndarray:
        """Return the servo signal F^j(k) of eq. 13 / Section II-G toward a training point.

        Parameters
        ----------
        X : array-like of shape (k, d) or (d,)
            Current views (one per row).
        cluster : int
            j, the cluster whose manifold the signal is computed on.
        target : int, optional
            Training index (row of the X given to ``fit``) of the desired position; it must
            belong to ``cluster``. Defaults to the cluster's centre ``centers_[cluster]``.

        Returns
        -------
        ndarray of shape (k,)
            ``F^j(k) = beta [(I - alpha S^j)^-1 Y^j]_k`` with ``beta = 1 - alpha``; larger is
            closer to the target along the manifold, 0 when x is unreachable at sigma_j.
        """
        check_is_fitted(self, "labels_")
        n_models, n = len(self._models), self.labels_.shape[0]
        if (
            isinstance(cluster, bool)
            or not isinstance(cluster, int | np.integer)
            or not 0 <= cluster < n_models
        ):
            raise ValueError(f"cluster must be an integer in [0, {n_models}), got {cluster!r}")
        if target is None:
            target = int(self.centers_[cluster])
        elif (
            isinstance(target, bool)
            or not isinstance(target, Integral)
            or not 0 <= target < n
            or self.labels_[target] != cluster
        ):
            raise ValueError(
                f"target must be the training index of a point of cluster {cluster}, got {target!r}"
            )
        return self.signals(X, [target])[:, 0]

    def signals(self, X: ArrayLike, targets: ArrayLike) -> np.ndarray:
        """Return `signal` (eq. 13) toward each of several training points.

        Each target is on its own cluster ``j = labels_[t]``, with the same numbers. A view's
        distances to a cluster's points (the costly part: one projection of the whole view)
        are computed once per cluster, not once per target: what a servo comparing waypoints
        needs each step.

        Parameters
        ----------
        X : array-like of shape (k, d) or (d,)
            Current views (one per row).
        targets : array-like of int
            Training indices of the desired positions.

        Returns
        -------
        ndarray of shape (k, len(targets))
            F^j(k) of each view toward each target.
        """
        X = np.asarray(X)
        X = self._check_query(X[None, :] if X.ndim == 1 else X)
        t = np.atleast_1d(np.asarray(targets))
        n = self.labels_.shape[0]
        if t.ndim != 1 or t.dtype.kind not in "iu" or ((t < 0) | (t >= n)).any():
            raise ValueError(f"targets must be training indices in [0, {n}), got {targets!r}")
        out, sq = np.empty((X.shape[0], t.size)), {}
        for i, target in enumerate(t):
            model = self._models[int(self.labels_[target])]
            if id(model) not in sq:
                sq[id(model)] = model.sq_distances(X)
            local = int(np.flatnonzero(model.indices == target)[0])
            out[:, i] = model.signal(sq[id(model)], local)
        return out
