"""Deprecated: the paper's synthetic sets moved to ``mapping.manifold``.

They are defined in ``mapping.manifold.synthetic``. This path works, with a
``DeprecationWarning``, for one release.
"""

from common.deprecation import moved_names

__getattr__, __dir__, __all__ = moved_names(
    __name__,
    dict.fromkeys(
        (
            "SYNTHETIC_SETS",
            "branching_sequences",
            "converging_paths",
            "lines_variable_spacing",
            "make_all",
            "parallel_lines",
            "plot_sets",
            "spirals_3d",
        ),
        "mapping.manifold",
    ),
)
