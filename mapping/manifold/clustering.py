"""Clustering along multiple visual manifolds (Grudic & Mulligan), as a scikit-learn estimator.

[`ManifoldClustering`][mapping.manifold.clustering.ManifoldClustering] implements Section II of the
paper: the manifold kernel ``U = beta (I - alpha S)^-1`` (eq. 1, 3), its normalised columns and
distances ``D_M`` (eq. 4-6), outlier vectors (eq. 10, 11) and seeds (eq. 12), recursive bisection
maximising Omega(2) over (sigma, alpha) (eq. 9) down to ``min_cluster_size``, the combination of the
C leaves into ``n_clusters``, and the out-of-sample signal F^j(k) of eq. 13 for prediction and
servoing. The functional cores are the other modules of `mapping.manifold`; the readings chosen
where the paper is ambiguous, and the evidence for them, are the decision records
``docs/decisions/001-*`` to ``010-*`` (listed in ``docs/guides/manifold-clustering.md``).
"""

from __future__ import annotations

from numbers import Integral, Real

import numpy as np
from numpy.typing import ArrayLike
from sklearn.base import BaseEstimator, ClusterMixin, _fit_context
from sklearn.utils._param_validation import Interval, StrOptions
from sklearn.utils.validation import validate_data

from common.blas import single_threaded_blas
from mapping.manifold.geometry import (
    KERNELS,
    DenseGeometry,
    GraphGeometry,
    training_geometry,
)
from mapping.manifold.graph_cluster_model import cluster_model
from mapping.manifold.queries import ManifoldQueries
from mapping.manifold.split import OMEGA_SIGNS, SEED_RULES, SearchSpace
from mapping.manifold.tree import COMBINE_RULES, build_tree, combine_tree, ensure_leaves
from mapping.split_tree import SplitNode
from mapping.validation import check_distinct_rows

__all__ = ["EXPECTED_FAILED_CHECKS", "ManifoldClustering"]

_NORMALIZATIONS = ("column", "none")
_DTYPES = ("float32", "float64")

# scikit-learn estimator checks that cannot apply to ManifoldClustering, with the reason; passed
# as ``expected_failed_checks`` to ``parametrize_with_checks`` (tests/mapping/test_sklearn_checks).
# None so far: every check of scikit-learn passes.
EXPECTED_FAILED_CHECKS: dict[str, str] = {}


# Centred values whose magnitude lies outside this band are stored in float64: in float32 a
# distance's products overflow (3.4e38) or vanish (1e-38) for d up to ~1e6 features.
_FLOAT32_SAFE = (1e-15, 1e15)


def _storage_dtype(requested: str, X: np.ndarray) -> np.dtype:
    """Return ``requested``, or float64 where float32 cannot hold X's distances.

    See ``store_dtype``.
    """
    dtype = np.dtype(requested)
    if dtype == np.float32:
        spread = float(np.ptp(X, axis=0).max())
        if not _FLOAT32_SAFE[0] <= spread <= _FLOAT32_SAFE[1]:
            return np.dtype(np.float64)
    return dtype


class ManifoldClustering(ManifoldQueries, ClusterMixin, BaseEstimator):
    """Clustering along manifolds with per-cluster kernel parameters (Grudic & Mulligan).

    Bisects the data recursively; each split chooses its own Gaussian width sigma and
    diffusion alpha by maximising Omega(2) (eq. 9) with a bounded 2-D search. Splitting stops
    when a node has fewer than ``2 * min_cluster_size`` points; the resulting C leaves are
    merged into ``n_clusters`` clusters, each with its own (sigma_j, alpha_j) and centre x_lj.
    New points are assigned by eq. 13, ``argmax_j F^j(k)``.

    Parameters
    ----------
    n_clusters : int, default 2
        K, the number of clusters (>= 1). With K = 1 all points form one cluster whose
        (sigma_1, alpha_1) are those of the root split (eq. 9 scores a cluster against the
        rest, which is empty then); ``predict`` is then trivial but ``signal`` still servos
        along the one manifold.
    min_cluster_size : int, default 10
        Q, the minimum number of points of a leaf of the bisection (>= 1);
        ``n_clusters * min_cluster_size`` must not exceed the number of samples. If the tree
        ends with fewer than K leaves (n close to K Q), the largest are split again, down to
        half their size, so a leaf may then hold fewer than Q points; a split that must move
        points to keep Q on each side may put copies of one sample in different leaves.
    n_sigmas : int, default 16
        Grid points of the sigma search per split (>= 2, log-spaced over the node's
        distances; one value would be no search).
    n_alphas : int, default 12
        Grid points of the alpha search per split.
    alpha_range : tuple of float, default (0.5, 0.9999)
        Bounds of alpha, inside (0, 1).
    refine : bool, default True
        Refine the best grid point of each split with nested bounded Brent searches.
    predict_alpha : float or None, default 0.99
        alpha of eq. 13 (the paper sets 0.99 "arbitrarily"); None uses each cluster's alpha_j.
    normalize : {"column", "none"}, default "column"
        How F^j(k) is made comparable across clusters in ``predict``: "column" divides by the
        norm of the cluster's kernel column at its centre (eq. 4's normalisation); "none"
        compares raw F^j(k) as printed.
    omega_sign : {"corrected", "printed"}, default "corrected"
        Reading of eq. 9; "printed" rewards spread within cluster 1 (kept for comparison).
    seed_rule : {"weighted", "printed"}, default "weighted"
        Reading of eq. 12 for the second seed (see ``mapping.manifold.kernel.seed_pair``).
    combine : str, default "spectral"
        How the C leaves become K clusters: "spectral", the reading that reproduces the paper,
        a normalised cut of the leaves' affinity in the manifold kernel (leaves kept whole;
        the sigma whose K groups have the largest total Omega(2), eq. 9); "coassociation", the
        cuts of every grid sigma combined by evidence accumulation (the leaves' co-association,
        cut into K by average linkage; Fred & Jain 2005); "consensus", the sigma whose cut
        agrees most with the other sigmas' (mean NMI; Strehl & Ghosh 2002)
        (``mapping.manifold.ensemble_combine``); "separability", repeatedly join the adjacent
        pair of groups least separable as two manifolds (eq. 9's spread on the pair, maximised
        over sigma and alpha); "merge", greedy merging by the sum of group-vs-rest Omega(2);
        or "cut", cutting the tree.
    store_dtype : {"float32", "float64"}, default "float32"
        dtype of the centred training points kept for ``predict`` and ``signal``; float32
        halves memory and the time of a ``signal`` call on image-sized vectors. Data whose
        centred values reach beyond float32's safe range (largest magnitude above 1e15 or
        below 1e-15, where products of two values overflow or vanish in float32) is kept in
        float64 whatever this says.
    projection_tol : float in [0, 1), default 0.0
        Largest fraction of a cluster's energy (sum of squared norms of its centred points)
        that the basis queries are projected onto may leave out. 0 keeps the whole span, and
        ``predict`` and ``signal`` agree with the direct distances to float32 round-off; a
        small value such as 1e-4 drops the weakest directions (mostly noise) and makes a call
        on image-sized vectors several times faster (``mapping.manifold.cluster_model``).
    kernel : {"auto", "dense", "sparse"}, default "auto"
        "dense": the exact n x n kernel. "sparse": affinities on a symmetrised k-NN graph and,
        per node above ``4 * n_components`` points, the top eigenpairs of S with the rest of
        the spectrum at its mean (``mapping.manifold.lowrank_kernel``), a search per split over the
        same ``n_sigmas`` grid without Brent's refinement of sigma,
        and eq. 13 on each cluster's graph (``mapping.manifold.graph_cluster_model``). "auto": dense
        up to 1000 samples (docs/decisions/006-dense-or-graph-kernel.md).
    n_neighbors : int, default 10
        k of the sparse path's graph, also the training points a new point is joined to;
        n or more means the complete graph.
    n_components : int, default 64
        Eigenpairs of S kept per (node, sigma) on the sparse path.
    n_jobs : int or None, default None
        Processes for the sparse path's split search: the root's grid of sigmas, then the
        nodes of each depth of the tree (``joblib``: None is 1 unless inside
        ``joblib.parallel_config``, -1 every core). The result does not depend on it. The
        dense path runs in one process (its time is its root's).

    Attributes
    ----------
    labels_ : ndarray of shape (n,)
        Cluster of each training point, 0..K-1, numbered by first appearance in X.
    centers_ : ndarray of shape (K,)
        Training index of each cluster's centre x_lj (minimum of eq. 11 in its own kernel).
    sigmas_, alphas_ : ndarray of shape (K,)
        sigma_j and alpha_j of each cluster: the maximiser of Omega(2) of "cluster j vs the
        rest" over the (sigma, alpha) grid.
    omegas_ : ndarray of shape (K,)
        That maximal Omega(2) of each cluster.
    tree_ : SplitNode
        The bisection tree; every inner node holds its split's Omega, sigma, alpha and seeds.
    leaf_labels_ : ndarray of shape (n,)
        Leaf of the tree of each training point, 0..C-1 left to right.
    outlier_scores_ : ndarray of shape (n,)
        Cluster-independent outlier vector O_d (eq. 10) in the kernel of the root split.
    cluster_outlier_scores_ : ndarray of shape (n,)
        O_d^j (eq. 11) of each point within its cluster, in the cluster's own kernel.
    n_features_in_ : int
        Number of features seen in ``fit``.

    Examples
    --------
    >>> import numpy as np
    >>> from mapping import ManifoldClustering
    >>> t = np.linspace(0, 1, 40)
    >>> X = np.concatenate([np.c_[t, 0 * t], np.c_[t, 0 * t + 0.3]])
    >>> model = ManifoldClustering(n_clusters=2, min_cluster_size=10).fit(X)
    >>> np.bincount(model.labels_).tolist()
    [40, 40]

    See Also
    --------
    mapping.baselines.NormalizedCutClustering : Normalised cut with one kernel width, the
        paper's baseline.
    mapping.baselines.SelfTuningSpectralClustering : Spectral clustering with local scaling.
    mapping.features.ImageFeatures : Images as the vectors this estimator clusters.
    servo.maps.ServoMap : A world's stored views, clustered by this estimator.
    """

    _parameter_constraints: dict = {
        "n_clusters": [Interval(Integral, 1, None, closed="left")],
        "min_cluster_size": [Interval(Integral, 1, None, closed="left")],
        "n_sigmas": [Interval(Integral, 2, None, closed="left")],
        "n_alphas": [Interval(Integral, 2, None, closed="left")],
        # a pair inside (0, 1); the bounds are checked in fit (no constraint type for pairs)
        "alpha_range": [tuple, list],
        "refine": ["boolean"],
        "predict_alpha": [Interval(Real, 0, 1, closed="neither"), None],
        "normalize": [StrOptions(set(_NORMALIZATIONS))],
        "omega_sign": [StrOptions(set(OMEGA_SIGNS))],
        "seed_rule": [StrOptions(set(SEED_RULES))],
        "combine": [StrOptions(set(COMBINE_RULES))],
        "store_dtype": [StrOptions(set(_DTYPES))],
        "projection_tol": [Interval(Real, 0, 1, closed="left")],
        "kernel": [StrOptions(set(KERNELS))],
        "n_neighbors": [Interval(Integral, 1, None, closed="left")],
        "n_components": [Interval(Integral, 1, None, closed="left")],
        "n_jobs": [Integral, None],
    }

    def __init__(
        self,
        n_clusters: int = 2,
        min_cluster_size: int = 10,
        *,
        n_sigmas: int = 16,
        n_alphas: int = 12,
        alpha_range: tuple[float, float] = (0.5, 0.9999),
        refine: bool = True,
        predict_alpha: float | None = 0.99,
        normalize: str = "column",
        omega_sign: str = "corrected",
        seed_rule: str = "weighted",
        combine: str = "spectral",
        store_dtype: str = "float32",
        projection_tol: float = 0.0,
        kernel: str = "auto",
        n_neighbors: int = 10,
        n_components: int = 64,
        n_jobs: int | None = None,
    ) -> None:
        self.n_clusters = n_clusters
        self.min_cluster_size = min_cluster_size
        self.n_sigmas = n_sigmas
        self.n_alphas = n_alphas
        self.alpha_range = alpha_range
        self.refine = refine
        self.predict_alpha = predict_alpha
        self.normalize = normalize
        self.omega_sign = omega_sign
        self.seed_rule = seed_rule
        self.combine = combine
        self.store_dtype = store_dtype
        self.projection_tol = projection_tol
        self.kernel = kernel
        self.n_neighbors = n_neighbors
        self.n_components = n_components
        self.n_jobs = n_jobs

    # ------------------------------------------------------------------ validation
    def _search_space(self, n_samples: int) -> SearchSpace:
        """Run the checks the parameter constraints cannot express; return the search grid.

        The grid is that of (sigma, alpha).
        """
        K, Q = self.n_clusters, self.min_cluster_size
        if K * Q > n_samples:
            raise ValueError(
                f"n_clusters * min_cluster_size = {K} * {Q} = {K * Q} exceeds the number of "
                f"samples ({n_samples})"
            )
        try:
            lo, hi = (float(v) for v in self.alpha_range)
        except (TypeError, ValueError):
            raise ValueError(
                f"alpha_range must be a pair (low, high) in (0, 1), got {self.alpha_range!r}"
            ) from None
        if not (0.0 < lo <= hi < 1.0):
            raise ValueError(
                f"alpha_range must lie in (0, 1) with low <= high, got {self.alpha_range!r}"
            )
        return SearchSpace(
            n_sigmas=int(self.n_sigmas),
            t_bounds=(-np.log10(1.0 - lo), -np.log10(1.0 - hi)),
            n_alphas=int(self.n_alphas),
            refine=bool(self.refine),
            omega_sign=self.omega_sign,
            seed_rule=self.seed_rule,
        )

    # ------------------------------------------------------------------ fit
    @_fit_context(prefer_skip_nested_validation=True)
    def fit(self, X: ArrayLike, y: None = None) -> ManifoldClustering:
        """Cluster the rows of X.

        Parameters
        ----------
        X : array-like of shape (n, d)
            Training points (images as vectors, scans, ...); finite, not all identical.
        y : None
            Ignored; present for scikit-learn compatibility.

        Returns
        -------
        ManifoldClustering
            self, fitted.
        """
        X = validate_data(self, X, dtype=[np.float64, np.float32], order="C", ensure_min_samples=2)
        n = X.shape[0]
        space = self._search_space(n)
        K, Q = int(self.n_clusters), int(self.min_cluster_size)
        # The big distance products (n x n, or the k-NN search) keep every BLAS thread.
        geometry = training_geometry(
            X, self.kernel, self.n_neighbors, self.n_components, self.n_jobs
        )
        check_distinct_rows(X, K)  # before the tree, not once it has run out of leaves
        with single_threaded_blas():
            self._fit_from_distances(X, geometry, K, Q, space)
        return self

    def _fit_from_distances(
        self, X: np.ndarray, D2: DenseGeometry | GraphGeometry, K: int, Q: int, space: SearchSpace
    ) -> None:
        # worker processes only for a graph fit: a dense fit's time is its root's (n = 600:
        # 4.3 s in one process, 4.6 s with two)
        n_jobs = self.n_jobs if isinstance(D2, GraphGeometry) else None
        tree = build_tree(D2, Q, space, n_jobs)
        # At least two leaves: the root split's kernel gives outlier_scores_ (and K = 1's).
        ensure_leaves(tree, D2, max(K, 2), space)
        leaves = [leaf.indices for leaf in tree.leaves()]
        combo = combine_tree(tree, D2, K, space, self.combine)

        members = [np.sort(np.concatenate([leaves[c] for c in g])) for g in combo.groups]
        # Number clusters by first appearance so labels do not depend on the merge order.
        order = np.argsort([idx[0] for idx in members], kind="stable")
        members = [members[k] for k in order]
        sigmas, alphas = combo.sigmas[order], combo.alphas[order]

        labels = np.empty(X.shape[0], dtype=np.intp)
        leaf_labels = np.empty(X.shape[0], dtype=np.intp)
        for c, idx in enumerate(leaves):
            leaf_labels[idx] = c
        inside = np.empty(X.shape[0])
        models, centres = [], []
        dtype = _storage_dtype(self.store_dtype, X)
        for j, idx in enumerate(members):
            labels[idx] = j
            # eq. 11 in the cluster's own kernel: the centre is the point "most inside".
            alpha_p = alphas[j] if self.predict_alpha is None else float(self.predict_alpha)
            model, o_j = cluster_model(
                X, D2, idx, sigmas[j], alphas[j], alpha_p, dtype, float(self.projection_tol)
            )
            inside[idx] = o_j
            centres.append(int(idx[model.centre]))
            models.append(model)

        self.labels_ = labels
        self.centers_ = np.array(centres, dtype=np.intp)
        self.sigmas_ = np.asarray(sigmas, dtype=np.float64)
        self.alphas_ = np.asarray(alphas, dtype=np.float64)
        self.omegas_ = combo.omegas[order]
        self.tree_: SplitNode = tree
        self.leaf_labels_ = leaf_labels
        # eq. 10 on all points, in the kernel of the root split (ensure_leaves split the root)
        self.outlier_scores_ = D2.outliers(tree.sigma, tree.alpha)
        self.cluster_outlier_scores_ = inside
        self._models = models
