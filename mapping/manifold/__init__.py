"""Visual-manifold clustering (Grudic & Mulligan).

From *Topological Mapping with Multiple Visual Manifolds*:
[`ManifoldClustering`][mapping.manifold.clustering.ManifoldClustering] and the per-cluster models
behind its F^j(k).

Where each part of the paper lives:

* ``kernel`` -- the affinity (eq. 1-2), the kernel ``U = (I - alpha S)^-1`` (eq. 3-5) and the
  outlier vectors; ``lowrank_kernel`` -- its low-rank form on a k-NN graph;
* ``geometry`` -- the training points as a dense affinity or a k-NN graph;
* ``split`` -- one split of a cluster by Omega(2) (eq. 6-12), choosing its sigma and alpha;
* ``tree`` -- the recursive splits into C leaves and their combination into K clusters
  (Section II-E); ``spectral_combine`` -- the default combination, a spectral cut of the leaves;
  ``ensemble_combine`` -- every grid sigma's cut combined (co-association, consensus);
* ``cluster_model`` and ``graph_cluster_model`` -- F^j(k) of a new view (eq. 13) for a dense
  and a graph cluster; ``signal_solvers`` -- eq. 13's two solvers; ``stacked_signal`` -- eq. 13
  for every cluster at once;
* ``queries`` -- ``predict``, ``predict_proba``, ``signal`` and ``signals`` of the estimator;
* ``clustering`` -- the estimator itself;
* ``synthetic`` -- the paper's four synthetic sets (Section III-A, Figure 1) and branching
  sequences, to cluster with known labels.
"""

from common.lazy import lazy_exports

__getattr__, __dir__, __all__ = lazy_exports(
    __name__,
    {
        "ClusterModel": "mapping.manifold.cluster_model",
        "EXPECTED_FAILED_CHECKS": "mapping.manifold.clustering",
        "GraphClusterModel": "mapping.manifold.graph_cluster_model",
        "ManifoldClustering": "mapping.manifold.clustering",
        "SYNTHETIC_SETS": "mapping.manifold.synthetic",
        "branching_sequences": "mapping.manifold.synthetic",
        "converging_paths": "mapping.manifold.synthetic",
        "lines_variable_spacing": "mapping.manifold.synthetic",
        "make_all": "mapping.manifold.synthetic",
        "parallel_lines": "mapping.manifold.synthetic",
        "plot_sets": "mapping.manifold.synthetic",
        "spirals_3d": "mapping.manifold.synthetic",
    },
)
