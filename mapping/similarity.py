"""Deprecated: the similarity graphs moved to ``mapping.grouping``.

They are defined in ``mapping.grouping.similarity``, the grouping method being their one user.
This path works, with a ``DeprecationWarning``, for one release.
"""

from common.deprecation import moved_names

__getattr__, __dir__, __all__ = moved_names(
    __name__,
    {"default_n_neighbors": "mapping.grouping", "knn_gaussian_affinity": "mapping.grouping"},
)
