"""Deprecated: ICP moved to ``mapping.scan_matching``.

It is defined in ``mapping.scan_matching.icp_alignment``. This path works, with a
``DeprecationWarning``, for one release.
"""

from common.deprecation import moved_names

__getattr__, __dir__, __all__ = moved_names(
    __name__,
    {
        **dict.fromkeys(("densify_scan", "icp", "icp_batch"), "mapping.scan_matching"),
        # what icp and icp_batch return, not on the face
        **dict.fromkeys(("IcpBatchResult", "IcpResult"), "mapping.scan_matching.icp_alignment"),
    },
)
