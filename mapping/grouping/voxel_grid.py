"""The voxel grid of the approximate sensed-space overlap (eq. 16-17 on voxels).

World points snap to square voxels anchored at the origin; a scan becomes the set of voxels
it occupies (`voxel_incidence`) and eq. 16's disc of radius ``delta`` becomes a set of
integer offsets (`voxel_offsets`), so "a point of the other scan within delta" becomes
"an occupied voxel of the other scan at one of those offsets" (`voxel_adjacency`).
Cells are addressed by row-major int64 ids where the bounding box allows, by rank where a
point far outside the map would overflow them; coordinates beyond int64 and voxels so fine
that the disc would hold more cells than the exact overlap costs are refused before anything
is allocated.
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np
import scipy.sparse as sp

__all__ = ["check_voxel_size", "voxel_adjacency", "voxel_incidence", "voxel_offsets"]

# Voxel grids with a bounding box up to this many cells use a dense lookup table (64 MB).
DENSE_GRID_MAX_CELLS = 8_000_000
# Row-major int64 cell ids address bounding boxes up to this many cells; beyond it (a point far
# outside the map, or a tiny voxel) the grid is indexed by rank instead (_ranked_adjacency).
KEY_MAX_CELLS = 2**62
# Voxel coordinates beyond this (in cells, either sign) are refused: int64 keeps them exact.
CELL_MAX = 2**61
# The disc of eq. 16 may be at most this many voxels wide (delta / voxel_size): each occupied
# voxel looks up every cell of the disc (~8,000 here), so a finer voxel costs more than the
# exact overlap (voxel_size=None) it approximates.
MAX_DISC_RADIUS = 50


def check_voxel_size(delta: float, voxel_size: float | None) -> None:
    """Refuse a ``voxel_size`` outside ``(0, delta]`` or finer than ``delta / MAX_DISC_RADIUS``.

    See ``voxel_offsets``; ``None`` (the exact overlap) passes.

    Parameters
    ----------
    delta : float
        Match tolerance in metres.
    voxel_size : float or None
        Voxel side in metres, or None for the exact overlap.

    Raises
    ------
    ValueError
        If ``voxel_size`` is out of range.
    """
    if voxel_size is None:
        return
    if not (np.isscalar(voxel_size) and 0 < voxel_size <= delta):
        raise ValueError(f"voxel_size must be None or in (0, delta = {delta}], got {voxel_size!r}")
    _check_disc_radius(float(delta) / float(voxel_size))


def _check_disc_radius(radius_cells: float) -> None:
    if not (np.isfinite(radius_cells) and radius_cells <= MAX_DISC_RADIUS + 1e-9):
        raise ValueError(
            f"voxel_size must be at least delta / {MAX_DISC_RADIUS} (match_distance / "
            f"{MAX_DISC_RADIUS} in ObservationGraphPartitioner): delta / voxel_size = "
            f"{radius_cells:.3g} voxels would make a disc of ~{np.pi * radius_cells**2:.3g} "
            "cells; use a larger voxel_size, or voxel_size=None for the exact overlap"
        )


def voxel_offsets(radius_cells: float) -> np.ndarray:
    """Return integer offsets ``(dx, dy)`` with ``dx^2 + dy^2 <= radius_cells^2``.

    They are the disc of eq. 16 on the voxel grid.

    Parameters
    ----------
    radius_cells : float
        Radius of the disc in voxels, ``delta / voxel_size``.

    Returns
    -------
    ndarray of int, shape (P, 2)
        The offsets, in lexicographic order.

    Raises
    ------
    ValueError
        If ``radius_cells`` (``delta / voxel_size``) is not finite or exceeds
        ``MAX_DISC_RADIUS``: a voxel that fine is refused before the disc is allocated.
    """
    _check_disc_radius(radius_cells)
    r = int(np.floor(radius_cells + 1e-9))
    dx, dy = np.meshgrid(np.arange(-r, r + 1), np.arange(-r, r + 1), indexing="ij")
    keep = dx**2 + dy**2 <= radius_cells**2 + 1e-9
    return np.column_stack([dx[keep], dy[keep]])


def _voxel_cells(points: np.ndarray, voxel_size: float) -> np.ndarray:
    """Return the integer voxel coordinates ``(P, 2)`` of world points.

    Coordinates so far out that int64 cannot hold them are refused (checked in floating
    point, before the cast).
    """
    with np.errstate(over="ignore"):
        scaled = np.floor(points / voxel_size)
    if not np.abs(scaled).max() <= CELL_MAX:  # also NaN, from points overflowed to inf
        lo, hi = points.min(axis=0), points.max(axis=0)
        raise ValueError(
            f"voxel_size = {voxel_size:.3g} m is too small for the extent of the points "
            f"(x from {lo[0]:.3g} to {hi[0]:.3g} m, y from {lo[1]:.3g} to {hi[1]:.3g} m): voxel "
            f"coordinates beyond {CELL_MAX:.3g} cells; a point or pose far outside the map (an "
            "unfiltered return?) or a voxel_size (match_distance / 4 by default) far too small"
        )
    return scaled.astype(np.int64)


def _box_cells(cells: np.ndarray, pad: int = 0) -> tuple[np.ndarray, list[int]]:
    """Return the lower corner and size of the bounding box of ``cells`` grown by ``pad``.

    The box is grown on every side; the size is in Python ints (no overflow).
    """
    lo = cells.min(axis=0) - pad
    span = [int(h) - int(low) + pad + 1 for h, low in zip(cells.max(axis=0), lo, strict=True)]
    return lo, span


def voxel_incidence(
    pts: Sequence[np.ndarray], voxel_size: float
) -> tuple[sp.csr_array, np.ndarray]:
    """Downsample world-frame scans to a voxel grid shared by all scans.

    The grid is anchored at the world origin, so the same place falls in the same voxel in
    every scan.

    Parameters
    ----------
    pts : sequence of ndarray of shape (M, 2)
        World-frame points of each scan.
    voxel_size : float
        Voxel side in metres.

    Returns
    -------
    A : scipy.sparse.csr_array of shape (n_scans, V)
        Incidence (scan x occupied voxel): ``A[i, u]`` is the number of points of scan ``i``
        in voxel ``u``.
    grid : ndarray of int64, shape (V, 2)
        Integer grid coordinates of the voxels, in row-major (lexicographic) order.

    Raises
    ------
    ValueError
        Naming ``voxel_size`` and the points' extent, if a voxel coordinate exceeds
        ``CELL_MAX`` (a point absurdly far out, or an absurdly small voxel).
    """
    sizes = np.array([len(p) for p in pts])
    if sizes.sum() == 0:
        return sp.csr_array((len(pts), 0)), np.empty((0, 2), dtype=np.int64)
    cells = _voxel_cells(np.concatenate(pts), voxel_size)
    lo, span = _box_cells(cells)
    if span[0] * span[1] <= KEY_MAX_CELLS:
        key = (cells[:, 0] - lo[0]) * span[1] + (cells[:, 1] - lo[1])  # row-major cell id
        voxels, column = np.unique(key, return_inverse=True)
        grid = np.column_stack([voxels // span[1] + lo[0], voxels % span[1] + lo[1]])
    else:  # ids would overflow int64: unique rows, sorted lexicographically (row-major)
        grid, column = np.unique(cells, axis=0, return_inverse=True)
        column = column.ravel()
    owner = np.repeat(np.arange(len(pts)), sizes)
    A = sp.csr_array((np.ones(len(column)), (owner, column)), shape=(len(pts), len(grid)))
    A.sum_duplicates()  # A[i, u] = the number of points of scan i in voxel u
    return A, grid


def _adjacency_from_hits(cols: np.ndarray, hit: np.ndarray) -> sp.csr_array:
    """Build the CSR adjacency from each voxel's looked-up columns (sorted per row) and hits."""
    indptr = np.concatenate([[0], np.cumsum(hit.sum(axis=1))])
    n = len(cols)
    return sp.csr_array((np.ones(int(indptr[-1])), cols[hit], indptr), shape=(n, n))


def voxel_adjacency(grid: np.ndarray, offsets: np.ndarray) -> sp.csr_array:
    """Return ``K`` with ``K[u, w] = 1`` when voxels ``u`` and ``w`` differ by one of ``offsets``.

    Parameters
    ----------
    grid : ndarray of int64, shape (V, 2)
        Occupied voxels, in row-major order (as ``voxel_incidence`` gives them).
    offsets : ndarray of int, shape (P, 2)
        The disc of ``voxel_offsets``.

    Returns
    -------
    scipy.sparse.csr_array of shape (V, V)
        Binary adjacency of the occupied voxels.
    """
    reach = int(np.abs(offsets).max())
    lo, span = _box_cells(grid, reach)
    if span[0] * span[1] > KEY_MAX_CELLS:
        return _ranked_adjacency(grid, offsets)
    key = (grid[:, 0] - lo[0]) * span[1] + (grid[:, 1] - lo[1])  # sorted: grid is row-major
    # offsets in lexicographic order shift the row-major keys in increasing order, so each
    # row's columns come out sorted and the CSR arrays are built directly
    shifts = np.sort(offsets[:, 0] * span[1] + offsets[:, 1])
    shifted = key[:, None] + shifts[None, :]  # (V, offsets)
    if span[0] * span[1] <= DENSE_GRID_MAX_CELLS:
        # a lookup table over the bounding box: one gather per offset
        table = np.full(span[0] * span[1], -1, dtype=np.int64)
        table[key] = np.arange(len(key))
        cols = table[shifted]
        hit = cols >= 0
    else:  # a huge, sparse map: binary search in the sorted keys instead
        cols = np.minimum(np.searchsorted(key, shifted), len(key) - 1)
        hit = key[cols] == shifted
    return _adjacency_from_hits(cols, hit)


def _ranked_adjacency(grid: np.ndarray, offsets: np.ndarray) -> sp.csr_array:
    """Run ``voxel_adjacency`` for a bounding box too large for row-major int64 ids.

    Rows and columns of the grid are numbered by their rank among the occupied ones: a cell
    off every occupied row or column holds no voxel, so a shifted cell is looked up only where
    both its coordinates are occupied ones. Ranks keep the row-major order and stay below
    ``V^2``, so the binary search in the sorted keys works as before.
    """
    xs, ys = np.unique(grid[:, 0]), np.unique(grid[:, 1])
    key = np.searchsorted(xs, grid[:, 0]) * len(ys) + np.searchsorted(ys, grid[:, 1])
    off = offsets[np.lexsort((offsets[:, 1], offsets[:, 0]))]  # lexicographic: sorted columns
    tx = grid[:, 0, None] + off[None, :, 0]
    ty = grid[:, 1, None] + off[None, :, 1]
    ix = np.minimum(np.searchsorted(xs, tx), len(xs) - 1)
    iy = np.minimum(np.searchsorted(ys, ty), len(ys) - 1)
    shifted = ix * len(ys) + iy
    cols = np.minimum(np.searchsorted(key, shifted), len(key) - 1)
    hit = (xs[ix] == tx) & (ys[iy] == ty) & (key[cols] == shifted)
    return _adjacency_from_hits(cols, hit)
