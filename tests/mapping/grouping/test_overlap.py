"""Sensed-space overlap (Blanco et al., eq. 16-18)."""

import numpy as np
import pytest
from scipy.spatial.distance import cdist

from mapping.grouping import office_path, office_world, raycast
from mapping.grouping.overlap import check_scans_and_poses, sensed_space_overlap, world_points


@pytest.fixture(scope="module")
def office():
    world = office_world()
    poses = office_path(world, step=1.17)
    return world, raycast(world.segments, poses), poses


def brute_force_overlap(scans, poses, delta):
    """Eq. 16-18 with all pairwise distances: the closed form the fast paths must match."""
    pts = world_points(scans, poses)
    n = len(pts)
    pi = np.zeros((n, n))
    for i in range(n):
        for j in range(n):
            if len(pts[i]) and len(pts[j]):
                pi[i, j] = np.mean(cdist(pts[i], pts[j]).min(axis=1) <= delta)
    return 0.5 * (pi + pi.T)


def test_hand_computed_pair():
    a = np.array([[0.0, 0.0], [1.0, 0.0]])
    b = np.array([[0.05, 0.0], [5.0, 5.0], [6.0, 6.0], [7.0, 7.0]])
    W = sensed_space_overlap([a, b], np.zeros((2, 3)), delta=0.1)
    # Pi(a, b) = 1/2, Pi(b, a) = 1/4, Psi = 3/8
    np.testing.assert_allclose(W, [[1.0, 0.375], [0.375, 1.0]])


@pytest.mark.parametrize("method", ["global", "per_scan"])
def test_tolerance_is_inclusive(method):
    # eq. 16 matches at ||p - q|| <= delta; 0.25 is exact in binary. Both exact paths: the
    # per-scan one (every real log takes it) bounds its KD-tree query, which is strict
    a, b = np.array([[0.0, 0.0]]), np.array([[0.25, 0.0]])
    W = sensed_space_overlap([a, b], np.zeros((2, 3)), delta=0.25, method=method)
    assert W[0, 1] == 1.0
    W = sensed_space_overlap([a, b], np.zeros((2, 3)), delta=0.2499, method=method)
    assert W[0, 1] == 0.0
    # one point at exactly delta in a scan of several, off both axes (the box filter of the
    # per-scan path and its candidate pruning see the same edge): 3-4-5 scaled to 0.25
    a = np.array([[0.0, 0.0], [-1.0, 0.0], [-2.0, 0.0]])
    b = np.array([[0.15, 0.2], [5.0, 5.0]])
    W = sensed_space_overlap([a, b], np.zeros((2, 3)), delta=0.25, method=method)
    assert W[0, 1] == pytest.approx((1 / 3 + 1 / 2) / 2)
    W = sensed_space_overlap([a, b], np.zeros((2, 3)), delta=0.2499, method=method)
    assert W[0, 1] == 0.0


@pytest.mark.parametrize("method", ["global", "per_scan"])
def test_pairs_within_delta_whose_boxes_do_not_touch_are_kept(method):
    # Two walls on one line, 0.05 m apart end to end: their bounding boxes do not touch (and
    # their centres are 2 * box radius + 0.05 apart), yet one point of each lies within delta
    # = 0.1 of the other, so the pair must survive the per-scan path's candidate pruning
    a = np.column_stack([np.linspace(0.0, 1.0, 11), np.zeros(11)])
    b = np.column_stack([np.linspace(1.05, 2.05, 11), np.zeros(11)])
    W = sensed_space_overlap([a, b], np.zeros((2, 3)), delta=0.1, method=method)
    np.testing.assert_allclose(W, brute_force_overlap([a, b], np.zeros((2, 3)), 0.1))
    assert W[0, 1] == pytest.approx(1 / 11)
    # diagonal neighbours: boxes apart in x and in y, the corners 0.06 apart (< delta)
    c = np.array([[0.0, 0.0], [1.0, 1.0]])
    d = c + 1.0 + 0.06 / np.sqrt(2)
    W = sensed_space_overlap([c, d], np.zeros((2, 3)), delta=0.1, method=method)
    assert W[0, 1] == pytest.approx(0.5)
    # and just beyond delta they share nothing
    W = sensed_space_overlap([a, b + [0.06, 0.0]], np.zeros((2, 3)), delta=0.1, method=method)
    assert W[0, 1] == 0.0


def test_poses_place_scans_in_the_world():
    # the same wall seen from two poses: the sensor-frame points differ, the world points agree
    wall = np.column_stack([np.full(20, 2.0), np.linspace(-1, 1, 20)])
    pose_b = np.array([1.0, 0.0, np.pi / 2])
    # world (3, y) seen from pose_b is (y, -(3 - 1)) in its frame
    seen_b = np.column_stack([wall[:, 1], -(wall[:, 0] + 1.0 - 1.0)])
    W = sensed_space_overlap([wall, seen_b], np.array([[1.0, 0.0, 0.0], pose_b]), 0.01)
    np.testing.assert_allclose(W[0, 1], 1.0)
    W_wrong = sensed_space_overlap([wall, seen_b], np.zeros((2, 3)), 0.01)
    assert W_wrong[0, 1] < 0.2


def test_symmetric_unit_diagonal_in_range(office):
    _, scans, poses = office
    W = sensed_space_overlap(scans, poses, 0.1)
    np.testing.assert_array_equal(W, W.T)
    np.testing.assert_array_equal(np.diag(W), 1.0)
    assert W.min() >= 0.0 and W.max() <= 1.0


@pytest.mark.parametrize("method", ["global", "per_scan"])
def test_matches_brute_force(office, method):
    _, scans, poses = office
    idx = np.arange(0, len(scans), 3)
    sub_scans, sub_poses = [scans[i] for i in idx], poses[idx]
    W = sensed_space_overlap(sub_scans, sub_poses, 0.1, method=method)
    np.testing.assert_allclose(W, brute_force_overlap(sub_scans, sub_poses, 0.1), atol=1e-12)


def test_sparse_output_equals_dense(office):
    _, scans, poses = office
    dense = sensed_space_overlap(scans, poses, 0.1)
    np.testing.assert_array_equal(
        sensed_space_overlap(scans, poses, 0.1, sparse=True).toarray(), dense
    )


def test_closed_rooms_share_nothing(office):
    world, scans, poses = office
    W = sensed_space_overlap(scans, poses, 0.1)
    region = world.region_labels(poses)
    # scans deep inside rooms 0 and 2 see disjoint walls (walls have thickness)
    in_room0 = np.flatnonzero((region == 0) & (poses[:, 1] > 4.0))
    in_room2 = np.flatnonzero((region == 2) & (poses[:, 1] > 4.0))
    assert in_room0.size and in_room2.size
    assert np.all(W[np.ix_(in_room0, in_room2)] == 0.0)
    assert W[in_room0[0], in_room0[1]] > 0.3


def test_empty_scan_overlaps_nothing(office):
    _, scans, poses = office
    scans = list(scans[:6])
    scans[2] = np.empty((0, 2))
    W = sensed_space_overlap(scans, poses[:6], 0.1)
    assert np.all(W[2] == 0.0) and np.all(W[:, 2] == 0.0)
    full = sensed_space_overlap(list(scans[:2]) + list(scans[3:6]), poses[[0, 1, 3, 4, 5]], 0.1)
    np.testing.assert_array_equal(W[np.ix_([0, 1, 3, 4, 5], [0, 1, 3, 4, 5])], full)


def test_single_scan_and_all_empty():
    np.testing.assert_array_equal(
        sensed_space_overlap([np.ones((3, 2))], np.zeros((1, 3)), 0.1), [[1.0]]
    )
    W = sensed_space_overlap([np.empty((0, 2))] * 3, np.zeros((3, 3)), 0.1)
    np.testing.assert_array_equal(W, np.zeros((3, 3)))


def test_deterministic(office):
    _, scans, poses = office
    np.testing.assert_array_equal(
        sensed_space_overlap(scans, poses, 0.1), sensed_space_overlap(scans, poses, 0.1)
    )


@pytest.mark.parametrize("delta", [0.0, -0.1, np.nan, np.inf])
def test_rejects_bad_delta(delta):
    with pytest.raises(ValueError, match="delta must be a positive finite"):
        sensed_space_overlap([np.ones((2, 2))], np.zeros((1, 3)), delta)


def test_rejects_bad_scans_and_poses():
    good = [np.zeros((3, 2)), np.ones((3, 2))]
    nan_scan = [good[0], np.array([[0.0, np.nan]])]
    with pytest.raises(ValueError, match=r"scans\[1\] contains NaN"):
        sensed_space_overlap(nan_scan, np.zeros((2, 3)), 0.1)
    with pytest.raises(ValueError, match=r"poses contains NaN or inf \(rows \[1\]\)"):
        sensed_space_overlap(good, np.array([[0, 0, 0], [0, np.nan, 0]]), 0.1)
    with pytest.raises(ValueError, match="poses and scans must have the same length"):
        sensed_space_overlap(good, np.zeros((3, 3)), 0.1)
    with pytest.raises(ValueError, match=r"scans\[0\] must have shape \(M, 2\)"):
        sensed_space_overlap([np.zeros((3, 3))], np.zeros((1, 3)), 0.1)
    with pytest.raises(ValueError, match=r"poses must have shape \(N, 3\)"):
        sensed_space_overlap(good, np.zeros((2, 2)), 0.1)
    with pytest.raises(ValueError, match="scans is empty"):
        sensed_space_overlap([], np.zeros((0, 3)), 0.1)
    with pytest.raises(ValueError, match="method must be one of"):
        sensed_space_overlap(good, np.zeros((2, 3)), 0.1, method="fast")


def brute_force_voxel_overlap(scans, poses, delta, voxel):
    """Eq. 16-18 with every point snapped to the centre of its voxel: the closed form the
    voxel path computes with sparse products."""
    cells = [np.floor(p / voxel) for p in world_points(scans, poses)]
    n = len(cells)
    pi = np.zeros((n, n))
    for i in range(n):
        for j in range(n):
            if len(cells[i]) and len(cells[j]):
                d2 = cdist(cells[i], cells[j], "sqeuclidean")  # in voxels, exact integers
                pi[i, j] = np.mean(d2.min(axis=1) <= (delta / voxel) ** 2 + 1e-9)
    return 0.5 * (pi + pi.T)


@pytest.mark.parametrize("voxel", [0.1, 0.05, 0.025, 0.03])
def test_voxel_path_is_the_sso_of_snapped_points(office, voxel, monkeypatch):
    _, scans, poses = office
    idx = np.arange(0, len(scans), 3)
    sub_scans, sub_poses = [scans[i] for i in idx], poses[idx]
    expected = brute_force_voxel_overlap(sub_scans, sub_poses, 0.1, voxel)
    np.fill_diagonal(expected, 1.0)
    W = sensed_space_overlap(sub_scans, sub_poses, 0.1, voxel_size=voxel)
    np.testing.assert_allclose(W, expected, atol=1e-12)
    # the binary search for maps too large for the lookup table gives the same matrix
    monkeypatch.setattr("mapping.grouping.voxel_grid.DENSE_GRID_MAX_CELLS", 0)
    np.testing.assert_array_equal(
        sensed_space_overlap(sub_scans, sub_poses, 0.1, voxel_size=voxel), W
    )


def test_voxel_path_stays_close_to_exact(office):
    # snapping to 2.5 cm voxels moves a point by <= 1.8 cm: a few matches at the tolerance flip
    _, scans, poses = office
    exact = sensed_space_overlap(scans, poses, 0.1)
    voxel = sensed_space_overlap(scans, poses, 0.1, voxel_size=0.025)
    assert np.abs(voxel - exact).max() < 0.05
    assert np.abs(voxel - exact)[exact > 0].mean() < 0.01
    assert np.mean((voxel > 0) != (exact > 0)) < 0.01


@pytest.mark.parametrize("voxel", [0.0, -0.01, 0.2, np.nan])
def test_rejects_bad_voxel_size(voxel):
    with pytest.raises(ValueError, match="voxel_size must be None or in"):
        sensed_space_overlap([np.ones((2, 2))] * 2, np.zeros((2, 3)), 0.1, voxel_size=voxel)


# --------------------------------------------------------------------------- voxel grid size


def test_voxel_path_without_row_major_ids_is_the_same(office, monkeypatch):
    # grids too wide for int64 row-major ids are indexed by rank: the same matrix
    _, scans, poses = office
    W = sensed_space_overlap(scans, poses, 0.1, voxel_size=0.025)
    monkeypatch.setattr("mapping.grouping.voxel_grid.KEY_MAX_CELLS", 0)
    np.testing.assert_array_equal(sensed_space_overlap(scans, poses, 0.1, voxel_size=0.025), W)


def test_voxel_grid_wider_than_int64_ids(office):
    # a tiny tolerance (8e10 voxels across the map) or one far return (4e10 voxels out):
    # the ids of the bounding box overflow int64, the overlap is still eq. 16-18 on the grid
    _, scans, poses = office
    idx = np.arange(0, len(scans), 3)
    sub_scans, sub_poses = [scans[i] for i in idx], poses[idx]
    with np.errstate(over="raise", invalid="raise"):
        tiny = sensed_space_overlap(sub_scans, sub_poses, 1e-9, voxel_size=2.5e-10)
    np.testing.assert_array_equal(tiny, sensed_space_overlap(sub_scans, sub_poses, 1e-9))
    far = list(sub_scans)
    far[2] = np.vstack([far[2], [[1e9, 1e9]]])
    expected = brute_force_voxel_overlap(far, sub_poses, 0.1, 0.025)
    np.fill_diagonal(expected, 1.0)
    with np.errstate(over="raise", invalid="raise"):
        W = sensed_space_overlap(far, sub_poses, 0.1, voxel_size=0.025)
    np.testing.assert_allclose(W, expected, atol=1e-12)


def test_voxel_coordinates_beyond_int64_are_refused():
    scans = [np.ones((3, 2))] * 2
    poses = np.array([[0.0, 0.0, 0.0], [1e300, 0.0, 0.0]])
    with pytest.raises(ValueError, match=r"voxel_size = 0.025 m is too small .* to 1e\+300 m"):
        sensed_space_overlap(scans, poses, 0.1, voxel_size=0.025)


def test_voxel_far_finer_than_delta_is_refused_at_once():
    # a disc of 3e16 voxels: refused before anything is allocated (it was a MemoryError)
    with pytest.raises(ValueError, match=r"voxel_size must be at least delta / 50 .* 1e\+08"):
        sensed_space_overlap([np.ones((2, 2))] * 2, np.zeros((2, 3)), 0.1, voxel_size=1e-9)


@pytest.mark.parametrize("scans", [None, 5, "scans"])
def test_scans_that_are_no_sequence_are_refused(scans):
    with pytest.raises(ValueError, match="scans must be a sequence of"):
        sensed_space_overlap(scans, np.zeros((1, 3)), 0.1)


@pytest.mark.parametrize("method", ["global", "per_scan"])
def test_tolerance_is_inclusive_along_y(method):
    # the per-scan path's box filter has a lower and an upper y edge: one pair meets both
    a, b = np.array([[0.0, 0.0]]), np.array([[0.0, 0.25]])
    W = sensed_space_overlap([a, b], np.zeros((2, 3)), delta=0.25, method=method)
    assert W[0, 1] == 1.0


@pytest.mark.parametrize("method", ["global", "per_scan"])
def test_a_scan_overlapping_nothing_does_not_hide_the_later_pairs(method):
    far = np.array([[100.0, 100.0]])
    a = np.array([[0.0, 0.0], [1.0, 0.0]])
    b = np.array([[0.05, 0.0], [5.0, 5.0], [6.0, 6.0], [7.0, 7.0]])
    W = sensed_space_overlap([far, a, b], np.zeros((3, 3)), delta=0.1, method=method)
    np.testing.assert_allclose(W, [[1.0, 0.0, 0.0], [0.0, 1.0, 0.375], [0.0, 0.375, 1.0]])


def test_scans_in_other_forms_and_their_errors():
    pts = np.array([[0.0, 0.0], [1.0, 0.0]])
    ref = sensed_space_overlap([pts, pts + 0.05], np.zeros((2, 3)), 0.1)
    stacked = np.stack([pts, pts + 0.05])  # one (N, M, 2) array
    np.testing.assert_array_equal(sensed_space_overlap(stacked, np.zeros((2, 3)), 0.1), ref)
    # an empty scan as a bare empty array, and the scans after it still checked
    W = sensed_space_overlap([np.array([]), pts, pts], np.zeros((3, 3)), 0.1)
    assert W[0, 0] == 0.0 and W[1, 2] == 1.0
    with pytest.raises(ValueError, match=r"^scans\[2\] must have shape \(M, 2\)"):
        sensed_space_overlap([np.array([]), pts, np.zeros((2, 3))], np.zeros((3, 3)), 0.1)
    with pytest.raises(
        ValueError,
        match=r"drop missed beams before calling \(an all-missed scan "
        r"is an empty \(0, 2\) array\)$",
    ):
        sensed_space_overlap([pts, [[0.0, np.inf]]], np.zeros((2, 3)), 0.1)
    with pytest.raises(ValueError, match="^scans must be a sequence of .* got ndarray$"):
        sensed_space_overlap(np.array(3.0), np.zeros((1, 3)), 0.1)
    with pytest.raises(ValueError, match="^scans is empty; need at least one scan$"):
        sensed_space_overlap([], np.zeros((0, 3)), 0.1)
    with pytest.raises(ValueError, match="got 4 poses and 2 scans$"):
        sensed_space_overlap([pts, pts], np.zeros((4, 3)), 0.1)
    poses = np.full((7, 3), np.nan)
    with pytest.raises(ValueError, match=r"\(rows \[0, 1, 2, 3, 4\]\)$"):
        sensed_space_overlap([pts] * 7, poses, 0.1)


def test_sparse_output_stores_only_overlaps():
    # the middle pair is a candidate (boxes within delta) whose points match nothing
    a, b = np.array([[0.0, 0.0], [0.0, 1.0]]), np.array([[0.15, 0.5], [5.0, 5.0]])
    W = sensed_space_overlap([a, b], np.zeros((2, 3)), 0.1, sparse=True, method="per_scan")
    assert W.toarray()[0, 1] == 0.0 and (W.data > 0).all() and W.nnz == 2


def test_a_candidate_pair_without_matches_stores_nothing():
    # boxes 0.05 apart (a candidate pair for delta 0.1), points at least 0.4 apart
    a, b = np.array([[0.0, 0.0], [0.0, 1.0]]), np.array([[0.05, 0.45], [0.05, 0.55]])
    W = sensed_space_overlap([a, b], np.zeros((2, 3)), 0.1, sparse=True, method="per_scan")
    assert W.nnz == 2 and W.toarray()[0, 1] == 0.0


def test_an_empty_scan_in_any_form_comes_back_as_0_by_2():
    # callers stack and transform the checked scans as (M, 2) arrays, empty ones included
    empties = [[], np.array([]), np.empty((0, 2)), np.empty((2, 0)), np.empty((0, 3))]
    scans, poses = check_scans_and_poses([*empties, [[1, 2]]], np.zeros((6, 3), dtype=int))
    assert [s.shape for s in scans] == [(0, 2)] * 5 + [(1, 2)]
    assert all(s.dtype == float for s in scans) and poses.dtype == float
    np.testing.assert_array_equal(np.concatenate(scans), [[1.0, 2.0]])
