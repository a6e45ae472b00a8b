"""Deprecated: ``run_starts_from_groups`` moved to ``mapping.run_starts``.

This path works, with a ``DeprecationWarning``, for one release.
"""

from common.deprecation import moved_names

__getattr__, __dir__, __all__ = moved_names(
    __name__, {"run_starts_from_groups": "mapping.run_starts"}
)
