"""The observation-grouping estimator of laser scans (Blanco et al., Sections III-IV).

``ObservationGraphPartitioner`` builds the observation graph of scans weighted by their
sensed-space overlap (``mapping.grouping.overlap``), splits it with the recursive min-Ncut of
``mapping.grouping.normalized_cut``, and turns the groups into local maps and a metric-topological
map (``mapping.grouping.topology``). It is a scikit-learn estimator:
``get_params``/``set_params``/``clone`` work, parameters are checked against
``_parameter_constraints``, and with ``affinity="precomputed"`` it partitions any ready-made
similarity graph.
"""

from __future__ import annotations

from collections.abc import Sequence
from numbers import Integral, Real

import numpy as np
import scipy.sparse as sp
from numpy.typing import ArrayLike
from sklearn.base import BaseEstimator, ClusterMixin
from sklearn.utils._param_validation import Interval, StrOptions

from common.geometry import se2_compose, se2_relative
from mapping.grouping.incremental_overlap import VoxelOverlapIndex, add_scans
from mapping.grouping.normalized_cut import (
    ASSOC,
    LAPLACIAN,
    SOLVERS,
    NcutNode,
    check_weights,
    recursive_ncut_partition,
)
from mapping.grouping.overlap import check_scans_and_poses, check_voxel_size, sensed_space_overlap
from mapping.grouping.topology import (
    TopologicalMap,
    build_local_maps,
    build_topology,
    fill_from_nearest,
    group_frames,
    run_starts_from_groups,
)
from mapping.scan_matching import refine_poses

__all__ = ["ObservationGraphPartitioner"]


class ObservationGraphPartitioner(ClusterMixin, BaseEstimator):
    """Group laser scans into local maps by sensed-space overlap and recursive min-Ncut.

    Blanco et al., Sections III-IV: every scan with its pose is a node of the observation graph
    (eq. 14); the weight of an arc is the sensed-space overlap of the two scans (eq. 15-18); the
    graph is split by recursive spectral bisection while the normalised cut is below
    ``threshold`` (eq. 1, 10-13). Each group's scans are merged into a local map and the groups
    are linked into a metric-topological map (Section IV-A, steps 3-4).

    Parameters
    ----------
    threshold : float, default 1.0
        Accept a bisection while its Ncut is below this (eq. 12-13); in ``[0, 2]``.
    match_distance : float, default 0.1
        Tolerance ``delta`` of eq. 16, in metres.
    voxel_size : float, "auto" or None, default "auto"
        Downsample the scans to a voxel grid of this side (metres, at most ``match_distance``
        and at least ``match_distance / 50``, ``mapping.grouping.voxel_grid.MAX_DISC_RADIUS``)
        before the overlap, as MRPT does (``mapping.grouping.overlap.sensed_space_overlap``);
        ``"auto"`` is ``match_distance / 4``; ``None`` computes eq. 16-18 exactly on every point
        (slower; docs/decisions/032-voxel-overlap.md compares both).
    affinity : {"sso", "precomputed"}, default "sso"
        ``"sso"``: ``fit(scans, poses)`` weighs the graph by the sensed-space overlap.
        ``"precomputed"``: ``fit(W)`` partitions the symmetric non-negative weight matrix ``W``
        (e.g. an image-similarity graph, ``knn_gaussian_affinity``); without poses there are
        no local maps or topology.
    assoc : {"mrpt", "paper"}, default "mrpt"
        How the association of eq. 1 is counted (see ``mapping.grouping.normalized_cut.ncut``);
        ``"mrpt"`` is the basis on which the threshold of 1 separates rooms, see
        ``docs/decisions/030-counting-assoc.md``.
    laplacian : {"normalized", "unnormalized"}, default "normalized"
        Eigenproblem of the bisection: eq. 10 (the paper) or MRPT's ``(D - W) y = lambda y``.
    min_size : int, default 1
        Smallest group a bisection may create.
    scan_matching : bool, default True
        Refine consecutive poses by ICP (``mapping.scan_matching.refine_poses``) before the
        overlap; on by default because raw odometry splits the default sequences
        (docs/decisions/033-pose-noise-and-icp.md).
    icp_max_distance : float, default 0.5
        Correspondence gate of the ICP in metres.
    icp_decimation : int, default 3
        The ICP matches every ``icp_decimation``-th point of each scan (``refine_poses``'s
        ``decimation``, MRPT's ``corresponding_points_decimation``). 3 was chosen on dev
        dataset seeds: about half the ICP's time, groups as good as with every point
        (docs/decisions/033-pose-noise-and-icp.md); 1 matches every point.
    empty_scans : {"nearest", "noise"}, default "nearest"
        Scans without points overlap nothing, so they stay out of the partition. ``"nearest"``
        gives each the group of the nearest scan with points along the trajectory (the earlier
        one on a tie); ``"noise"`` labels them -1.
    solver : {"auto", "dense", "sparse"}, default "auto"
        Eigensolver of the bisections.

    Attributes
    ----------
    labels_ : ndarray of shape (N,)
        Group of each scan, numbered in order of first appearance.
    affinity_matrix_ : scipy.sparse.csr_array of shape (N, N)
        The weights ``W``: the sensed-space overlap (eq. 18), or the precomputed matrix.
    split_tree_ : NcutNode
        The recursive bisection with each Ncut (indices into all scans).
    n_groups_ : int
    poses_ : ndarray of shape (N, 3)
        Poses used for the overlap (ICP-refined when ``scan_matching``); ``affinity="sso"`` only,
        like the two attributes below.
    local_maps_ : list of ndarray of shape (P_k, 2)
        Each group's points in the frame of its reference scan ``topology_.reference_scans[k]``
        (the scan closest to the group's mean position; see
        ``mapping.grouping.topology.group_frames``).
    topology_ : mapping.grouping.topology.TopologicalMap
        Groups as nodes, arcs with relative transformations between local-map frames.

    Examples
    --------
    >>> from mapping import ObservationGraphPartitioner
    >>> from mapping.grouping import office_path, office_world, raycast
    >>> world = office_world()
    >>> poses = office_path(world, step=1.17)
    >>> model = ObservationGraphPartitioner(scan_matching=False)
    >>> model.fit(raycast(world.segments, poses), poses).n_groups_
    8

    See Also
    --------
    mapping.grouping.sensed_space_overlap : The weights of the observation graph (eq. 16-18).
    mapping.grouping.recursive_ncut_partition : The recursive min-Ncut with threshold 1.
    mapping.grouping.TopologicalMap : The map in ``topology_``.
    mapping.manifold.ManifoldClustering : The visual-manifold method, on images.
    """

    _parameter_constraints: dict = {
        "threshold": [Interval(Real, 0.0, 2.0, closed="both")],
        "match_distance": [Interval(Real, 0.0, None, closed="neither")],
        "voxel_size": [Interval(Real, 0.0, None, closed="neither"), StrOptions({"auto"}), None],
        "affinity": [StrOptions({"sso", "precomputed"})],
        "assoc": [StrOptions(set(ASSOC))],
        "laplacian": [StrOptions(set(LAPLACIAN))],
        "min_size": [Interval(Integral, 1, None, closed="left")],
        "scan_matching": ["boolean"],
        "icp_max_distance": [Interval(Real, 0.0, None, closed="neither")],
        "icp_decimation": [Interval(Integral, 1, None, closed="left")],
        "empty_scans": [StrOptions({"nearest", "noise"})],
        "solver": [StrOptions(set(SOLVERS))],
    }

    def __init__(
        self,
        threshold: float = 1.0,
        match_distance: float = 0.1,
        *,
        voxel_size: float | str | None = "auto",
        affinity: str = "sso",
        assoc: str = "mrpt",
        laplacian: str = "normalized",
        min_size: int = 1,
        scan_matching: bool = True,
        icp_max_distance: float = 0.5,
        icp_decimation: int = 3,
        empty_scans: str = "nearest",
        solver: str = "auto",
    ) -> None:
        self.threshold = threshold
        self.match_distance = match_distance
        self.voxel_size = voxel_size
        self.affinity = affinity
        self.assoc = assoc
        self.laplacian = laplacian
        self.min_size = min_size
        self.scan_matching = scan_matching
        self.icp_max_distance = icp_max_distance
        self.icp_decimation = icp_decimation
        self.empty_scans = empty_scans
        self.solver = solver

    def __sklearn_tags__(self):
        """Return scikit-learn's tags; a precomputed affinity is a pairwise, sparse input."""
        tags = super().__sklearn_tags__()
        tags.input_tags.pairwise = self.affinity == "precomputed"
        tags.input_tags.sparse = self.affinity == "precomputed"
        tags.input_tags.two_d_array = self.affinity == "precomputed"
        return tags

    def fit(
        self,
        X: Sequence[ArrayLike] | ArrayLike | sp.sparray,
        poses: ArrayLike | None = None,
        *,
        groups: ArrayLike | None = None,
    ) -> ObservationGraphPartitioner:
        """Group the scans ``X`` taken at ``poses`` and build the local maps and topology.

        Parameters
        ----------
        X : sequence of array-like of shape (M_i, 2), or (N, N) matrix
            ``affinity="sso"``: the points of each scan in its sensor frame (``M_i`` may be 0).
            ``affinity="precomputed"``: the symmetric non-negative weights (dense or sparse).
        poses : array-like of shape (N, 3)
            World poses ``(x, y, yaw)`` of the scans, e.g. odometry; required for ``"sso"``,
            not used with ``"precomputed"``. It takes the place of scikit-learn's ``y``.
        groups : array-like of shape (N,), optional
            The run (drive) each scan belongs to, scikit-learn's per-sample convention (as in
            ``GroupKFold``), when several drives of the same place are grouped together in one
            common frame; each run's scans are consecutive. The overlap does not care, but
            consecutive scans of different runs are not trajectory neighbours: the scan
            matching does not chain across them, arcs ``via`` the trajectory do not join them,
            and an empty scan takes its group from its own run. Default: one run.

        Returns
        -------
        self
        """
        self._validate_params()
        _check_x_given(X, self.affinity)
        self.__dict__.pop("_incremental", None)  # a new fit ends any partial_fit sequence
        if self.affinity == "precomputed":
            return self._fit_precomputed(X, poses, groups)
        if poses is None:
            raise ValueError("poses is required with affinity='sso': fit(scans, poses)")
        voxel_size = self._voxel_size()  # checked before the scan matching's work
        scans, poses = check_scans_and_poses(X, poses)
        starts = run_starts_from_groups(groups, len(scans))
        if self.scan_matching:
            poses = self._refine(scans, poses, groups)
        W = sensed_space_overlap(
            scans, poses, self.match_distance, sparse=True, voxel_size=voxel_size
        )
        has_points = np.array([len(s) > 0 for s in scans])
        kept = np.flatnonzero(has_points)
        labels = np.full(len(scans), -1, dtype=np.intp)
        if kept.size:
            sub_labels, tree = self._partition(W[kept][:, kept])
            labels[kept] = sub_labels
            _reindex(tree, kept)
        else:
            tree = NcutNode(np.arange(0))
        if self.empty_scans == "nearest":
            labels = fill_from_nearest(labels, starts)
        self.poses_ = poses
        self.affinity_matrix_ = W
        self.split_tree_ = tree
        self.labels_ = labels
        self.n_groups_ = int(labels.max()) + 1
        reference, frames = group_frames(poses, labels)
        self.local_maps_ = build_local_maps(scans, poses, labels, frames)
        self.topology_: TopologicalMap = build_topology(poses, labels, W, reference, frames, groups)
        return self

    def fit_predict(
        self,
        X: Sequence[ArrayLike] | ArrayLike | sp.sparray,
        poses: ArrayLike | None = None,
        *,
        groups: ArrayLike | None = None,
    ) -> np.ndarray:
        """Run ``fit`` and return ``labels_``.

        Parameters
        ----------
        X : sequence of array-like of shape (M_i, 2), or (N, N) matrix
            The scans, or the precomputed weights (see ``fit``).
        poses : array-like of shape (N, 3), optional
            World poses of the scans; required for ``"sso"``.
        groups : array-like of shape (N,), optional
            The run (drive) of each scan; default one run.

        Returns
        -------
        ndarray of int, shape (N,)
            Group of each scan.
        """
        return self.fit(X, poses, groups=groups).labels_

    def partial_fit(self, X: Sequence[ArrayLike], poses: ArrayLike) -> ObservationGraphPartitioner:
        """Add scans as the robot drives and update the groups incrementally.

        Each new scan (in driving order, one run) becomes a node; its overlaps to the scans
        already there come from a voxel index restricted by pose and range
        (``mapping.grouping.incremental_overlap.VoxelOverlapIndex``: the same weights as ``fit``'s
        voxel overlap), and only the groups it overlaps are merged with it and partitioned again
        (``mapping.grouping.incremental_overlap.repartition``), as MRPT's incremental partitioner
        does. The result is the same graph as ``fit`` on all scans so far; the groups are the same
        wherever a new scan's groups are not joined to the rest (e.g. a new building, or a
        room seen from nowhere else), and otherwise a local re-partition of what changed.

        ``labels_``, ``n_groups_``, ``poses_`` and ``affinity_matrix_`` are updated;
        ``local_maps_`` and ``topology_`` are rebuilt when read; ``split_tree_`` is not kept.
        ``fit`` starts over. Needs ``affinity="sso"`` and a ``voxel_size``.

        Parameters
        ----------
        X : sequence of array-like of shape (M_i, 2)
            The new scans, sensor-frame points.
        poses : array-like of shape (k, 3)
            Their poses, continuing the poses given so far (with ``scan_matching`` the
            increments from the previous scan are refined by ICP, as in ``fit``).

        Returns
        -------
        self
        """
        self._validate_params()
        if self.affinity == "precomputed" or self.voxel_size is None:
            raise ValueError("partial_fit needs affinity='sso' and a voxel_size (not None)")
        if hasattr(self, "labels_") and "_incremental" not in self.__dict__:
            raise ValueError(
                "this model was fitted with fit(); partial_fit continues only a partial_fit "
                "sequence: start it on an unfitted estimator (e.g. clone(model))"
            )
        _check_x_given(X, self.affinity)
        scans, given = check_scans_and_poses(X, poses)
        state = self.__dict__.setdefault(
            "_incremental",
            {
                "index": VoxelOverlapIndex(self.match_distance, self._voxel_size()),
                "scans": [],
                "given": np.empty((0, 3)),
                "poses": np.empty((0, 3)),
                "arcs": [(np.empty(0, np.intp),) * 2 + (np.empty(0),)],
                "raw": np.empty(0, dtype=np.intp),
            },
        )
        poses_now = self._chain(state, scans, given)
        options = {k: getattr(self, k) for k in ("threshold", "assoc", "laplacian", "solver")}
        rows, cols, vals, raw = add_scans(
            state, scans, poses_now, min_size=self.min_size, **options
        )
        state.update(
            scans=state["scans"] + scans,
            given=np.concatenate([state["given"], given]),
            poses=np.concatenate([state["poses"], poses_now]),
            arcs=[(rows, cols, vals)],
            raw=raw,
        )
        n = raw.size
        labels = fill_from_nearest(raw) if self.empty_scans == "nearest" else raw
        self.labels_ = labels
        self.n_groups_ = int(labels.max()) + 1
        self.poses_ = state["poses"]
        self.affinity_matrix_ = sp.csr_array((vals, (rows, cols)), shape=(n, n))
        for name in ("split_tree_", "local_maps_", "topology_"):
            self.__dict__.pop(name, None)  # local maps and topology: rebuilt when read
        return self

    def _chain(self, state: dict, scans: list, given: np.ndarray) -> np.ndarray:
        """Return the poses of the new scans.

        As given, or ICP-refined increments chained from the last refined pose
        (``refine_poses`` on the previous scan and the new ones).
        """
        if not self.scan_matching:
            return given
        if not state["scans"]:
            return self._refine(scans, given)
        previous = [state["scans"][-1], *scans]
        ext = self._refine(previous, np.concatenate([state["given"][-1:], given]))
        return se2_compose(state["poses"][-1], se2_relative(ext[0], ext[1:]))

    def _refine(self, scans, poses, groups=None) -> np.ndarray:
        """Run ``refine_poses`` with this estimator's ICP settings."""
        return refine_poses(
            scans,
            poses,
            max_correspondence_distance=self.icp_max_distance,
            groups=groups,
            decimation=self.icp_decimation,
        )

    def __getattr__(self, name: str):
        """Build ``local_maps_`` and ``topology_`` after ``partial_fit`` on first read."""
        # local maps and topology after partial_fit, built on first read
        state = self.__dict__.get("_incremental")
        if name not in ("local_maps_", "topology_") or state is None:
            raise AttributeError(f"{type(self).__name__!r} object has no attribute {name!r}")
        reference, frames = group_frames(state["poses"], self.labels_)
        self.local_maps_ = build_local_maps(state["scans"], state["poses"], self.labels_, frames)
        self.topology_ = build_topology(
            state["poses"], self.labels_, self.affinity_matrix_, reference, frames
        )
        return self.__dict__[name]

    def _fit_precomputed(self, W, poses, groups) -> ObservationGraphPartitioner:
        if poses is not None or groups is not None:
            raise ValueError(
                "poses and groups are not used with affinity='precomputed'; pass only the "
                "weight matrix: fit(W)"
            )
        W = check_weights(W, "X (the precomputed affinity)")
        if W.shape[0] == 0:
            raise ValueError("X (the precomputed affinity) has no nodes")
        self.labels_, self.split_tree_ = self._partition(W)
        self.affinity_matrix_ = sp.csr_array(W)
        self.n_groups_ = int(self.labels_.max()) + 1
        for name in ("poses_", "local_maps_", "topology_"):  # left from an earlier "sso" fit
            self.__dict__.pop(name, None)
        return self

    def _voxel_size(self) -> float | None:
        """Return the voxel side for the overlap, checked against ``match_distance``."""
        if self.voxel_size == "auto":
            return self.match_distance / 4
        if self.voxel_size is not None and self.voxel_size > self.match_distance:
            raise ValueError(
                f"voxel_size ({self.voxel_size}) must not exceed match_distance "
                f"({self.match_distance}): a voxel wider than the tolerance merges what eq. 16 "
                "tells apart"
            )
        check_voxel_size(self.match_distance, self.voxel_size)  # not too fine either
        return self.voxel_size

    def _partition(self, W) -> tuple[np.ndarray, NcutNode]:
        return recursive_ncut_partition(
            W,
            self.threshold,
            assoc=self.assoc,
            laplacian=self.laplacian,
            min_size=self.min_size,
            solver=self.solver,
        )


def _check_x_given(X, affinity: str) -> None:
    """Refuse ``X=None`` with the form ``fit`` expects for ``affinity``."""
    if X is None:
        form = "the (N, N) weight matrix W"
        if affinity != "precomputed":
            form = "the scans, a sequence of (M_i, 2) point arrays"
        raise ValueError(f"X must be {form} (affinity={affinity!r}), got None")


def _reindex(tree: NcutNode, kept: np.ndarray) -> None:
    """Map the tree's indices from the partitioned subset back to all scans."""
    for node in tree.walk():
        node.indices = kept[node.indices]
