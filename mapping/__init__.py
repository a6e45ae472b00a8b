"""Mapping methods: visual-manifold clustering (Grudic & Mulligan) and laser observation
grouping (Blanco et al.), their baselines, features and metrics.

Public names are imported lazily so that ``import mapping`` stays cheap.
"""

from importlib import import_module

# name -> module that defines it (one line per name, keep sorted by module)
_EXPORTS = {
    "NormalizedCutClustering": "mapping.baselines",
    "SelfTuningSpectralClustering": "mapping.baselines",
    "ManifoldClustering": "mapping.manifold",
    "clustering_error": "mapping.metrics",
    "sensed_space_overlap": "mapping.overlap",
    "ObservationGraphPartitioner": "mapping.partition",
    "ncut": "mapping.partition",
    "spectral_bisection": "mapping.partition",
}

__all__ = sorted(_EXPORTS)


def __getattr__(name):
    try:
        module = _EXPORTS[name]
    except KeyError:
        raise AttributeError(f"module 'mapping' has no attribute {name!r}") from None
    return getattr(import_module(module), name)
