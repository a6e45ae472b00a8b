"""``ObservationGraphPartitioner`` passes each setting on: to the ICP, to the recursive min-Ncut
and its eigensolver, and to the topology (its reference scans and the runs)."""

import numpy as np
import pytest

from mapping.grouping import normalized_cut, office_path, office_world, raycast
from mapping.grouping.normalized_cut import recursive_ncut_partition
from mapping.grouping.partitioner import ObservationGraphPartitioner
from mapping.scan_matching import refine_poses
from tests.mapping.grouping.weighted_graphs import UNEVEN


@pytest.fixture(scope="module")
def office():
    world = office_world()
    poses = office_path(world, step=1.17)
    return raycast(world.segments, poses), poses


def clique(n: int, w: float) -> np.ndarray:
    W = np.full((n, n), w)
    np.fill_diagonal(W, 1.0)
    return W


def test_the_icp_settings_reach_the_scan_matching(office):
    scans, poses = office
    scans = scans[:8]
    odometry = poses[:8] + np.random.default_rng(0).normal(scale=[0.05, 0.05, 0.02], size=(8, 3))
    refined = {}
    # the defaults (0.5 m, every third point), then each setting changed alone
    for distance, decimation in ((0.5, 3), (1.0, 3), (0.5, 1)):
        model = ObservationGraphPartitioner(icp_max_distance=distance, icp_decimation=decimation)
        model.fit(scans, odometry)
        expected = refine_poses(
            scans, odometry, max_correspondence_distance=distance, decimation=decimation
        )
        np.testing.assert_array_equal(model.poses_, expected)
        refined[distance, decimation] = expected
    # each setting changes the poses, so the check above sees whether it was passed on
    assert not np.allclose(refined[0.5, 3], refined[1.0, 3], rtol=0, atol=1e-3)
    assert not np.allclose(refined[0.5, 3], refined[0.5, 1], rtol=0, atol=1e-3)


def test_assoc_reaches_the_recursion():
    # eq. 3's volume splits a clique of weight 0.8 into single nodes; MRPT's count keeps it
    W = clique(12, 0.8)
    paper = ObservationGraphPartitioner(affinity="precomputed", assoc="paper").fit(W)
    np.testing.assert_array_equal(paper.labels_, recursive_ncut_partition(W, assoc="paper")[0])
    assert paper.n_groups_ == 12
    assert ObservationGraphPartitioner(affinity="precomputed").fit(W).n_groups_ == 1


def test_laplacian_reaches_the_recursion():
    W = UNEVEN  # its normalized and unnormalized bisections differ
    first = {}
    for laplacian in ("normalized", "unnormalized"):
        model = ObservationGraphPartitioner(
            affinity="precomputed", threshold=2.0, laplacian=laplacian
        ).fit(W)
        _, tree = recursive_ncut_partition(W, threshold=2.0, laplacian=laplacian)
        np.testing.assert_array_equal(
            model.split_tree_.children[0].indices, tree.children[0].indices
        )
        first[laplacian] = tuple(tree.children[0].indices)
    assert first["normalized"] != first["unnormalized"]


@pytest.mark.parametrize("solver, sparse_calls", [("auto", False), ("sparse", True)])
def test_solver_reaches_the_eigensolver(office, monkeypatch, solver, sparse_calls):
    calls = []
    solve = normalized_cut._sparse_second_eigenvector
    monkeypatch.setattr(
        normalized_cut, "_sparse_second_eigenvector", lambda *a: calls.append(1) or solve(*a)
    )
    scans, poses = office
    model = ObservationGraphPartitioner(scan_matching=False, solver=solver).fit(scans, poses)
    assert bool(calls) == sparse_calls  # "auto" is dense at this size
    reference = ObservationGraphPartitioner(scan_matching=False, solver="dense").fit(scans, poses)
    np.testing.assert_array_equal(model.labels_, reference.labels_)
    # a partial_fit of a few scans re-partitions graphs of under 6 nodes: solved dense
    few = ObservationGraphPartitioner(scan_matching=False, solver=solver)
    assert few.partial_fit(scans[:5], poses[:5]).labels_.shape == (5,)


def test_the_topology_keeps_the_reference_scans_and_the_runs(office):
    # two runs 1 km apart: no overlap joins them, and the trajectory does not either, because
    # the first scan of the second run does not follow the last of the first
    scans, poses = office
    n = 12
    far = poses[:n] + [1000.0, 0.0, 0.0]
    model = ObservationGraphPartitioner(scan_matching=False)
    model.fit(list(scans[:n]) * 2, np.concatenate([poses[:n], far]), groups=np.repeat([0, 1], n))
    topology = model.topology_
    reference = topology.reference_scans
    np.testing.assert_array_equal(model.labels_[reference], np.arange(model.n_groups_))
    np.testing.assert_array_equal(topology.frames, model.poses_[reference])
    first_run = set(model.labels_[:n].tolist())
    assert first_run.isdisjoint(model.labels_[n:].tolist())
    assert topology.arcs  # arcs within each run
    for arc in topology.arcs:
        assert (arc.source in first_run) == (arc.target in first_run)
    # one run: the trajectory joins the last scan of the first part to the next one
    joined = ObservationGraphPartitioner(scan_matching=False)
    joined.fit(list(scans[:n]) * 2, np.concatenate([poses[:n], far]))
    i, j = joined.labels_[n - 1], joined.labels_[n]
    assert any({arc.source, arc.target} == {i, j} for arc in joined.topology_.arcs)


def test_a_too_fine_voxel_is_refused_before_the_scan_matching(office, monkeypatch):
    calls = []
    monkeypatch.setattr(
        "mapping.grouping.partitioner.refine_poses", lambda *a, **k: calls.append(1)
    )
    scans, poses = office
    model = ObservationGraphPartitioner(match_distance=0.1, voxel_size=1e-4)  # below 0.1 / 50
    with pytest.raises(ValueError, match="^voxel_size must be at least delta / 50"):
        model.fit(scans, poses)
    assert not calls  # no ICP spent on a fit that cannot finish
