"""Consistent observation grouping (Blanco, Gonzalez & Fernandez-Madrigal).

2-D laser scans with poses grouped into local metric maps by recursive min-Ncut of their
sensed-space overlap.

* ``partitioner`` --
  [`ObservationGraphPartitioner`][mapping.grouping.partitioner.ObservationGraphPartitioner], the
  estimator;
* ``overlap`` -- the sensed-space overlap (SSO) weights of the observation graph, over the
  voxel grid of ``voxel_grid``; ``incremental_overlap`` -- the same, updated scan by scan;
* ``normalized_cut`` -- Ncut, spectral bisection and the recursive partition with threshold 1;
* ``topology`` -- the groups' local maps joined in a topological map;
* ``local_maps`` -- the local maps aligned by ICP and scored;
* ``pose_graph`` -- loop closure over the groups (GTSAM);
* ``similarity`` -- kNN Gaussian similarity graphs of feature vectors (e.g. images), the
  weights of a ``"precomputed"`` partition;
* ``synthetic_scans`` -- a small office of walls, a path through it, ray-cast scans and noisy
  odometry: scans with known rooms for tests, docs and benchmarks.
"""

from common.lazy import lazy_exports

__getattr__, __dir__, __all__ = lazy_exports(
    __name__,
    {
        "absolute_trajectory_error": "mapping.grouping.pose_graph",
        "align_groups": "mapping.grouping.local_maps",
        "close_loops": "mapping.grouping.pose_graph",
        "default_n_neighbors": "mapping.grouping.similarity",
        "knn_gaussian_affinity": "mapping.grouping.similarity",
        "localise_held_out": "mapping.grouping.local_maps",
        "map_residuals": "mapping.grouping.local_maps",
        "ncut": "mapping.grouping.normalized_cut",
        "ObservationGraphPartitioner": "mapping.grouping.partitioner",
        "office_path": "mapping.grouping.synthetic_scans",
        "office_world": "mapping.grouping.synthetic_scans",
        "raycast": "mapping.grouping.synthetic_scans",
        "recursive_ncut_partition": "mapping.grouping.normalized_cut",
        "sensed_space_overlap": "mapping.grouping.overlap",
        "simulate_odometry": "mapping.grouping.synthetic_scans",
        "spectral_bisection": "mapping.grouping.normalized_cut",
        "submap_labels": "mapping.grouping.local_maps",
        "TopologicalMap": "mapping.grouping.topology",
        "VoxelOverlapIndex": "mapping.grouping.incremental_overlap",
        "world_points": "mapping.grouping.overlap",
    },
)
