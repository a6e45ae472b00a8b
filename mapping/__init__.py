"""Mapping methods: visual-manifold clustering and laser observation grouping.

Visual-manifold clustering (Grudic & Mulligan) and laser observation grouping (Blanco et al.),
their baselines, features and metrics.

The methods are subpackages: `mapping.manifold` (the manifold clustering, its F^j(k)
queries and the paper's synthetic sets), `mapping.grouping` (the observation-graph
partitioner, its overlap, Ncut, local maps, topological map and similarity graphs, and a
synthetic office of scans), `mapping.baselines` (the spectral clusterings a user would
compare with), `mapping.features` (image and scan features) and `mapping.scan_matching` (ICP
and odometry refined by it, which the grouping and the servo maps share). The modules beside
them are shared by both methods: metrics, distances, where each run of a recording begins
(`run_starts`), the split tree, persistence and validation. Public names are imported lazily
so that ``import mapping`` stays cheap.
"""

from common.lazy import lazy_exports

__getattr__, __dir__, __all__ = lazy_exports(
    __name__,
    {
        "scan_to_points": "common.geometry",
        "EigengapNCutClustering": "mapping.baselines",
        "KNNSpectralClustering": "mapping.baselines",
        "NormalizedCutClustering": "mapping.baselines",
        "SelfTuningSpectralClustering": "mapping.baselines",
        "best_sigma_ncut": "mapping.baselines",
        "ColorHistogramFeatures": "mapping.features",
        "ImageFeatures": "mapping.features",
        "ScanFeatures": "mapping.features",
        "ScanStatistics": "mapping.features",
        "ObservationGraphPartitioner": "mapping.grouping",
        "TopologicalMap": "mapping.grouping",
        "ncut": "mapping.grouping",
        "recursive_ncut_partition": "mapping.grouping",
        "sensed_space_overlap": "mapping.grouping",
        "spectral_bisection": "mapping.grouping",
        "icp": "mapping.scan_matching",
        "ManifoldClustering": "mapping.manifold",
        "adjusted_rand_index": "mapping.metrics",
        "clustering_error": "mapping.metrics",
        "purity": "mapping.metrics",
        "refine_poses": "mapping.scan_matching",
        "SplitNode": "mapping.split_tree",
        "NotFittedError": "sklearn.exceptions",  # what every estimator here raises before fit
    },
)
