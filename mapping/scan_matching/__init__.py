"""Scan matching: 2-D laser scans registered to each other by point-to-point ICP in SE(2).

Also odometry refined by matching consecutive scans.

* ``icp_alignment`` -- [`icp`][mapping.scan_matching.icp_alignment.icp] of one pair of scans,
  ``icp_batch`` of many at once, and ``densify_scan``, the target they match against;
* ``pose_refinement`` --
  [`refine_poses`][mapping.scan_matching.pose_refinement.refine_poses], each odometry increment
  replaced by the ICP of consecutive scans.

Shared by the grouping method (its poses and local maps) and the servo maps and controller.
"""

from common.lazy import lazy_exports

__getattr__, __dir__, __all__ = lazy_exports(
    __name__,
    {
        "densify_scan": "mapping.scan_matching.icp_alignment",
        "icp": "mapping.scan_matching.icp_alignment",
        "icp_batch": "mapping.scan_matching.icp_alignment",
        "refine_poses": "mapping.scan_matching.pose_refinement",
    },
)
