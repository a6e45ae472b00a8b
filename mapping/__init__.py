"""Mapping methods: visual-manifold clustering (Grudic & Mulligan) and laser observation
grouping (Blanco et al.), their baselines, features and metrics.

Public names are imported lazily so that ``import mapping`` stays cheap.
"""

from importlib import import_module

# name -> module that defines it (one line per name, keep sorted by module)
_EXPORTS = {
    "scan_to_points": "common.geometry",
    "NormalizedCutClustering": "mapping.baselines",
    "SelfTuningSpectralClustering": "mapping.baselines",
    "best_sigma_ncut": "mapping.baselines",
    "ColorHistogramFeatures": "mapping.image_features",
    "ImageFeatures": "mapping.image_features",
    "ScanFeatures": "mapping.features",
    "ScanStatistics": "mapping.scan_statistics",
    "EigengapNCutClustering": "mapping.label_free",
    "KNNSpectralClustering": "mapping.label_free",
    "icp": "mapping.icp",
    "refine_poses": "mapping.scan_matching",
    "ManifoldClustering": "mapping.manifold",
    "adjusted_rand_index": "mapping.metrics",
    "clustering_error": "mapping.metrics",
    "purity": "mapping.metrics",
    "ncut": "mapping.ncut",
    "recursive_ncut_partition": "mapping.ncut",
    "spectral_bisection": "mapping.ncut",
    "sensed_space_overlap": "mapping.overlap",
    "ObservationGraphPartitioner": "mapping.partition",
    "SplitNode": "mapping.split_tree",
    "TopologicalMap": "mapping.topology",
    "NotFittedError": "sklearn.exceptions",  # what every estimator here raises before fit
}

__all__ = sorted(_EXPORTS)


def __getattr__(name):
    try:
        module = _EXPORTS[name]
    except KeyError:
        raise AttributeError(f"module 'mapping' has no attribute {name!r}") from None
    return getattr(import_module(module), name)
