"""Organic shapes built with trimesh: lumpy tree canopies, tapered trunks, bushes and rocks.

Meshes are embedded in the MJCF inline (``<mesh vertex=... face=...>``), so a world is one
XML string plus its texture PNGs, with no mesh files on disk. Vertex noise comes only from
the ``numpy.random.Generator`` passed in.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import TYPE_CHECKING

import numpy as np

if TYPE_CHECKING:  # trimesh is imported where a mesh is built: it takes ~1 s to import, and
    import trimesh  # ``import scenes`` is on every command's path, ``topomap --help`` included

CANOPY_SUBDIVISIONS = 2  # 162 vertices: lumpy enough, cheap to render on llvmpipe
TRUNK_SECTIONS = 10


@dataclass(frozen=True)
class Mesh:
    """A triangle mesh as MJCF wants it: float vertices (V, 3) and int faces (F, 3)."""

    vertices: np.ndarray
    faces: np.ndarray

    def vertex_attr(self) -> str:
        return " ".join(f"{v:.4f}" for v in self.vertices.ravel())

    def face_attr(self) -> str:
        return " ".join(str(int(f)) for f in self.faces.ravel())


def _from_trimesh(mesh: trimesh.Trimesh) -> Mesh:
    return Mesh(np.asarray(mesh.vertices, np.float64), np.asarray(mesh.faces, np.int64))


def _lumpy(mesh: trimesh.Trimesh, rng: np.random.Generator, amount: float) -> trimesh.Trimesh:
    import trimesh

    # Smooth radial noise: random per-vertex offsets averaged with their neighbours, so the
    # surface bulges like foliage instead of looking spiky.
    offsets = rng.normal(0.0, amount, len(mesh.vertices))
    neighbours = mesh.vertex_neighbors
    smooth = np.array(
        [0.5 * offsets[i] + 0.5 * offsets[n].mean() for i, n in enumerate(neighbours)]
    )
    normals = mesh.vertex_normals
    return trimesh.Trimesh(mesh.vertices + normals * smooth[:, None], mesh.faces, process=False)


def canopy(rng: np.random.Generator, radius: float, squash: float = 0.8) -> Mesh:
    """A tree crown: an icosphere with smooth radial lumps, squashed vertically."""
    import trimesh

    sphere = trimesh.creation.icosphere(subdivisions=CANOPY_SUBDIVISIONS, radius=radius)
    lumpy = _lumpy(sphere, rng, 0.18 * radius)
    lumpy.vertices[:, 2] *= squash
    return _from_trimesh(lumpy)


def trunk(rng: np.random.Generator, radius: float, height: float) -> Mesh:
    """A tapered, slightly leaning trunk (a cone frustum with jittered rings)."""
    import trimesh

    cyl = trimesh.creation.cylinder(radius=radius, height=height, sections=TRUNK_SECTIONS)
    v = cyl.vertices.copy()
    top = v[:, 2] > 0
    v[top, :2] *= 0.6  # taper
    lean = rng.normal(0.0, 0.03 * height, 2)
    v[top, :2] += lean
    v[:, 2] += height / 2.0  # base at z = 0
    return Mesh(v, np.asarray(cyl.faces, np.int64))


def bush(rng: np.random.Generator, radius: float) -> Mesh:
    """A low shrub: a flattened lumpy sphere sitting on the ground."""
    import trimesh

    sphere = trimesh.creation.icosphere(subdivisions=CANOPY_SUBDIVISIONS, radius=radius)
    lumpy = _lumpy(sphere, rng, 0.22 * radius)
    lumpy.vertices[:, 2] = lumpy.vertices[:, 2] * 0.7 + 0.7 * radius
    return _from_trimesh(lumpy)


def rock(rng: np.random.Generator, radius: float) -> Mesh:
    """A garden rock: a coarse, strongly jittered icosphere half sunk into the ground."""
    import trimesh

    sphere = trimesh.creation.icosphere(subdivisions=1, radius=radius)
    lumpy = _lumpy(sphere, rng, 0.3 * radius)
    lumpy.vertices[:, 2] *= 0.6
    return _from_trimesh(lumpy)


def gable_roof(length: float, depth: float, height: float) -> Mesh:
    """A triangular prism roof (ridge along x), base centred at the origin at z = 0."""
    import trimesh

    hx, hy = length / 2.0, depth / 2.0
    v = np.array(
        [[-hx, -hy, 0], [hx, -hy, 0], [hx, hy, 0], [-hx, hy, 0], [-hx, 0, height], [hx, 0, height]],
        np.float64,
    )
    return _from_trimesh(trimesh.convex.convex_hull(v))
