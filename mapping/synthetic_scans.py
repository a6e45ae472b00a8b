"""Deprecated: the synthetic office of laser scans moved to ``mapping.grouping``.

It is defined in ``mapping.grouping.synthetic_scans``. This path works, with a
``DeprecationWarning``, for one release.
"""

from common.deprecation import moved_names

__getattr__, __dir__, __all__ = moved_names(
    __name__,
    {
        **dict.fromkeys(
            ("office_path", "office_world", "raycast", "simulate_odometry"), "mapping.grouping"
        ),
        # what office_world returns, not on the face
        "OfficeWorld": "mapping.grouping.synthetic_scans",
    },
)
