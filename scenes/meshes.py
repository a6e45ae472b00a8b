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
    """A triangle mesh as MJCF wants it: float vertices (V, 3) and int faces (F, 3).

    Parameters
    ----------
    vertices : ndarray of shape (V, 3)
        The vertices, m.
    faces : ndarray of shape (F, 3), int
        Each triangle's vertex indices.
    texcoords : ndarray of shape (V, 2) or None, default None
        Where a texture is laid on each vertex.
    """

    vertices: np.ndarray
    faces: np.ndarray
    texcoords: np.ndarray | None = None  # (V, 2): where a texture is laid on each vertex

    def vertex_attr(self) -> str:
        """Return the vertices as MJCF's ``vertex`` attribute.

        Returns
        -------
        str
            The coordinates, space-separated, 4 decimals.
        """
        return " ".join(f"{v:.4f}" for v in self.vertices.ravel())

    def face_attr(self) -> str:
        """Return the faces as MJCF's ``face`` attribute.

        Returns
        -------
        str
            The vertex indices, space-separated.
        """
        return " ".join(str(int(f)) for f in self.faces.ravel())

    def texcoord_attr(self) -> str | None:
        """Return the texture coordinates as MJCF's ``texcoord`` attribute.

        Returns
        -------
        str or None
            The coordinates, space-separated, 4 decimals; None without texture coordinates.
        """
        if self.texcoords is None:
            return None
        return " ".join(f"{v:.4f}" for v in self.texcoords.ravel())


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
    """Build a tree crown: an icosphere with smooth radial lumps, squashed vertically.

    Parameters
    ----------
    rng : numpy.random.Generator
        The generator of the lumps.
    radius : float
        The sphere's radius, m.
    squash : float, default 0.8
        Factor on the vertices' heights.

    Returns
    -------
    Mesh
        The crown, centred at the origin.
    """
    import trimesh

    sphere = trimesh.creation.icosphere(subdivisions=CANOPY_SUBDIVISIONS, radius=radius)
    lumpy = _lumpy(sphere, rng, 0.18 * radius)
    lumpy.vertices[:, 2] *= squash
    return _from_trimesh(lumpy)


def trunk(rng: np.random.Generator, radius: float, height: float) -> Mesh:
    """Build a tapered, slightly leaning trunk (a cone frustum with jittered rings).

    Parameters
    ----------
    rng : numpy.random.Generator
        The generator of the lean.
    radius : float
        The base's radius, m (the top's is 0.6 of it).
    height : float
        The trunk's height, m.

    Returns
    -------
    Mesh
        The trunk, base at z = 0.
    """
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
    """Build a low shrub: a flattened lumpy sphere sitting on the ground.

    Parameters
    ----------
    rng : numpy.random.Generator
        The generator of the lumps.
    radius : float
        The sphere's radius, m.

    Returns
    -------
    Mesh
        The shrub.
    """
    import trimesh

    sphere = trimesh.creation.icosphere(subdivisions=CANOPY_SUBDIVISIONS, radius=radius)
    lumpy = _lumpy(sphere, rng, 0.22 * radius)
    lumpy.vertices[:, 2] = lumpy.vertices[:, 2] * 0.7 + 0.7 * radius
    return _from_trimesh(lumpy)


def rock(rng: np.random.Generator, radius: float) -> Mesh:
    """Build a garden rock: a coarse, strongly jittered icosphere half sunk into the ground.

    Parameters
    ----------
    rng : numpy.random.Generator
        The generator of the jitter.
    radius : float
        The sphere's radius, m.

    Returns
    -------
    Mesh
        The rock.
    """
    import trimesh

    sphere = trimesh.creation.icosphere(subdivisions=1, radius=radius)
    lumpy = _lumpy(sphere, rng, 0.3 * radius)
    lumpy.vertices[:, 2] *= 0.6
    return _from_trimesh(lumpy)


def gable_roof(length: float, depth: float, height: float) -> Mesh:
    """Build a triangular prism roof (ridge along x), base centred at the origin at z = 0.

    Parameters
    ----------
    length : float
        Its extent along x, m.
    depth : float
        Its extent along y, m.
    height : float
        The ridge's height, m.

    Returns
    -------
    Mesh
        The roof.
    """
    import trimesh

    hx, hy = length / 2.0, depth / 2.0
    v = np.array(
        [[-hx, -hy, 0], [hx, -hy, 0], [hx, hy, 0], [-hx, hy, 0], [-hx, 0, height], [hx, 0, height]],
        np.float64,
    )
    return _from_trimesh(trimesh.convex.convex_hull(v))


def floor_slab(ring: np.ndarray, centre, thickness: float, texture_scale: float = 1.0) -> Mesh:
    """Build a flat prism over a polygon ``ring``, top face at z = 0.

    The texture coordinates are in metres / ``texture_scale``, so that it tiles like the floor
    slabs around it.

    Parameters
    ----------
    ring : array_like of shape (m, 2)
        The polygon, counter-clockwise, star-shaped from ``centre``, m.
    centre : array_like of shape (2,)
        The point the polygon is star-shaped from (a junction's hub), m.
    thickness : float
        The prism's thickness, m.
    texture_scale : float, default 1.0
        Metres per texture repeat.

    Returns
    -------
    Mesh
        The slab, with texture coordinates.
    """
    ring = np.asarray(ring, np.float64)
    m = len(ring)
    p = np.vstack([np.asarray(centre, np.float64), ring])
    n = m + 1
    top = np.column_stack([p, np.zeros(n)])
    bottom = np.column_stack([p, np.full(n, -thickness)])
    fan = [(0, 1 + k, 1 + (k + 1) % m) for k in range(m)]
    faces = fan + [(n + a, n + c, n + b) for a, b, c in fan]
    for k in range(m):
        a, b = 1 + k, 1 + (k + 1) % m
        faces += [(a, n + a, n + b), (a, n + b, b)]
    uv = np.concatenate([p, p]) / texture_scale
    return Mesh(np.concatenate([top, bottom]), np.asarray(faces, np.int64), uv)
