"""A built world: its MJCF, texture assets and ground truth (manifolds, free space, routes).

The builders (`scenes.hallway`, `scenes.lawn`) make one;
[`scenes.build_world`][scenes.registry.build_world] (`scenes.registry`) picks the builder by name.
"""

from __future__ import annotations

import hashlib
import os
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from common.fileio import atomic_write_bytes
from scenes.appearance import Appearance
from scenes.regions import Footprint, ManifoldMap, OccupancyGrid, Route, rasterise_free_space


@dataclass
class World:
    """A world ready to simulate, with its ground truth.

    Attributes
    ----------
    name : str
        ``"hallway"``, ``"lawn"`` or a generated world's ``FAMILY:SEED``
        (`scenes.families`).
    xml : str
        The MJCF model (robot included).
    assets : dict[str, bytes]
        Texture PNGs the MJCF refers to, for ``MjModel.from_xml_string(xml, assets)``.
    manifolds : ManifoldMap
        The world's named manifolds as floor regions, with their label ids (4 in each
        canonical world, 2 to 12 in a generated one).
    footprints : list[Footprint]
        Floor shadow of every colliding geom.
    bounds : tuple
        ``(xmin, xmax, ymin, ymax)`` of the walkable area, metres.
    routes : dict[str, Route]
        Teleop routes, one per leaf manifold: from the main manifold's start through every
        junction on the way to the leaf's end.
    appearance : dict
        The randomisation parameters this world was built with.
    randomized : bool
        Whether those were drawn (else the defaults).
    appearance_mode : str
        One of `APPEARANCE_MODES`.
    parents : dict[str, str or None]
        Each manifold's parent in the world's tree of stretches (None for the main one).
    digest : str
        SHA-256 of the floor plan (the manifold regions, their names and ids): two worlds
        with the same digest have the same layout, whatever they look like.

    Parameters
    ----------
    name, xml, assets, manifolds, footprints, bounds, routes, appearance
        The attributes above, as [`scenes.build_world`][scenes.registry.build_world] makes them.
    randomized : bool, default False
        Whether the appearance was drawn.
    appearance_mode : str, default "default"
        One of `APPEARANCE_MODES`.
    parents : dict, optional
        Default: the first manifold is the main one and every other leaves from it (the
        canonical worlds' single junction).
    digest : str, optional
        Default: computed from ``manifolds``.

    Examples
    --------
    >>> from scenes import build_world
    >>> world = build_world("lawn")
    >>> world.name, list(world.routes)
    ('lawn', ['lawn-left', 'lawn-straight', 'lawn-right'])
    >>> world.manifold_names[:2], world.manifold_ids["lawn"]
    (('lawn', 'lawn-left'), 4)
    >>> world.manifolds.name_of(world.manifold_at([[8.0, 2.0]])[0])
    'lawn'

    See Also
    --------
    scenes.build_world : Builds a world by name.
    sim.simulator.Simulator : Simulates it.
    """

    name: str
    xml: str
    assets: dict[str, bytes]
    manifolds: ManifoldMap
    footprints: list[Footprint]
    bounds: tuple[float, float, float, float]
    routes: dict[str, Route]
    appearance: dict
    randomized: bool = False
    appearance_mode: str = "default"
    parents: dict = None
    digest: str = None
    # Free-space grids already rasterised, per (resolution, inflation). A World compares by
    # value and is mutable, so it is not hashable; the cache lives on the instance instead.
    _free_space: dict = field(default_factory=dict, init=False, repr=False, compare=False)

    def __post_init__(self):
        """Fill in the default ``parents`` and ``digest``; check ``parents`` names the manifolds."""
        names = self.manifolds.names
        if self.parents is None:
            self.parents = {n: (None if k == 0 else names[0]) for k, n in enumerate(names)}
        if set(self.parents) != set(names):
            raise ValueError(f"parents must name exactly the manifolds {names}")
        if self.digest is None:
            self.digest = layout_digest(self.manifolds)

    @classmethod
    def from_scene(
        cls,
        name: str,
        scene,
        app: Appearance,
        manifolds: ManifoldMap,
        bounds: tuple[float, float, float, float],
        routes: dict[str, Route],
        parents: dict | None = None,
        digest: str | None = None,
    ) -> World:
        """Return the finished world of a built `SceneBuilder` scene.

        Parameters
        ----------
        name : str
            The world's name.
        scene : SceneBuilder
            The built scene: its MJCF, assets and footprints.
        app : Appearance
            The appearance draw the scene was built with.
        manifolds : ManifoldMap
            The world's manifolds as floor regions.
        bounds : tuple of float
            ``(xmin, xmax, ymin, ymax)`` of the walkable area, m.
        routes : dict of str to Route
            Teleop routes, one per leaf manifold.
        parents : dict or None, default None
            Each manifold's parent; None: every manifold leaves from the first.
        digest : str or None, default None
            SHA-256 of the floor plan; None: computed from ``manifolds``.

        Returns
        -------
        World
            The world.
        """
        return cls(
            name=name,
            xml=scene.to_xml(),
            assets=scene.assets,
            manifolds=manifolds,
            footprints=scene.footprints,
            bounds=bounds,
            routes=routes,
            appearance=dict(app.params),
            randomized=app.rng is not None,
            appearance_mode=app.mode,
            parents=parents,
            digest=digest,
        )

    @property
    def manifold_names(self) -> tuple[str, ...]:
        """The world's manifolds in the order of their label ids."""
        return self.manifolds.names

    @property
    def manifold_ids(self) -> dict[str, int]:
        """Label id of each manifold (the canonical lawn's are 4 to 7, as the paper's rows)."""
        return dict(self.manifolds.ids)

    def junctions_between(self, a: str, b: str) -> int:
        """Count the junctions between manifolds ``a`` and ``b``.

        Parameters
        ----------
        a, b : str
            Names of two of the world's manifolds.

        Returns
        -------
        int
            The number of junctions (0 for one manifold; two branches of one junction are 1
            apart).

        Raises
        ------
        ValueError
            When ``a`` or ``b`` is no manifold of the world.
        """

        def up(m):
            if m not in self.parents:
                raise ValueError(f"manifold must be one of {self.manifold_names}, got {m!r}")
            path = [m]
            while self.parents[path[-1]] is not None:
                path.append(self.parents[path[-1]])
            return path[::-1]

        pa, pb = up(a), up(b)
        common = 0
        while common < min(len(pa), len(pb)) and pa[common] == pb[common]:
            common += 1
        up_a, up_b = len(pa) - common, len(pb) - common
        return up_a + up_b - (1 if up_a and up_b else 0)

    def manifold_at(self, xy) -> np.ndarray:
        """Return the manifold ids at points.

        Parameters
        ----------
        xy : array_like of shape (..., 2)
            Points on the floor, m.

        Returns
        -------
        ndarray of shape (...)
            Indices into [`scenes.names.MANIFOLDS`][scenes.names.MANIFOLDS]; -1 off every
            manifold.
        """
        return self.manifolds.label_at(xy)

    def free_space(self, resolution: float = 0.05, inflation: float = 0.0) -> OccupancyGrid:
        """Return the occupancy grid of the walkable floor (cached per arguments).

        Parameters
        ----------
        resolution : float, default 0.05
            Cell size, m.
        inflation : float, default 0.0
            Distance obstacles are grown by (the robot's radius), m.

        Returns
        -------
        OccupancyGrid
            The free cells of the floor.
        """
        key = (float(resolution), float(inflation))
        if key not in self._free_space:
            self._free_space[key] = rasterise_free_space(
                self.manifolds, self.footprints, self.bounds, *key
            )
        return self._free_space[key]

    def write(self, directory: str | os.PathLike) -> Path:
        """Write ``<name>.xml`` and its textures, for MuJoCo's own viewer (``simulate``).

        Parameters
        ----------
        directory : str or os.PathLike
            The folder to write into (created if missing).

        Returns
        -------
        Path
            The ``.xml`` file (a ``:`` in the name written as ``-``).
        """
        directory = Path(directory)
        directory.mkdir(parents=True, exist_ok=True)
        for file, data in self.assets.items():
            atomic_write_bytes(directory / file, data)
        path = directory / f"{self.name.replace(':', '-')}.xml"  # no ':' in a file name
        atomic_write_bytes(path, self.xml.encode())
        return path


def layout_digest(manifolds: ManifoldMap) -> str:
    """Return the SHA-256 of a world's manifold regions (names, ids, polygons to a micrometre).

    Parameters
    ----------
    manifolds : ManifoldMap
        The world's manifolds.

    Returns
    -------
    str
        64 hex digits.
    """
    h = hashlib.sha256()
    for name in manifolds.names:
        h.update(f"{name}:{manifolds.ids[name]};".encode())
    for region in manifolds.regions:
        h.update(region.manifold.encode())
        h.update(np.round(np.asarray(region.polygon, np.float64), 6).tobytes())
    return h.hexdigest()
