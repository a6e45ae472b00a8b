"""A built world: its MJCF, texture assets and ground truth (manifolds, free space, routes).

The builders (:mod:`scenes.hallway`, :mod:`scenes.lawn`) make one; :func:`scenes.build_world`
(:mod:`scenes.registry`) picks the builder by name.
"""

from __future__ import annotations

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
        ``"hallway"`` or ``"lawn"``.
    xml : str
        The MJCF model (robot included).
    assets : dict[str, bytes]
        Texture PNGs the MJCF refers to, for ``MjModel.from_xml_string(xml, assets)``.
    manifolds : ManifoldMap
        The 4 named manifolds as floor regions.
    footprints : list[Footprint]
        Floor shadow of every colliding geom.
    bounds : tuple
        ``(xmin, xmax, ymin, ymax)`` of the walkable area, metres.
    routes : dict[str, Route]
        Teleop routes, one per branch: main manifold, then the branch.
    appearance : dict
        The randomisation parameters this world was built with.
    randomized : bool
        Whether those were drawn (else the defaults).
    appearance_mode : str
        One of :data:`APPEARANCE_MODES`.

    Parameters
    ----------
    name, xml, assets, manifolds, footprints, bounds, routes, appearance
        The attributes above, as :func:`scenes.build_world` makes them.
    randomized : bool, default False
        Whether the appearance was drawn.
    appearance_mode : str, default "default"
        One of :data:`APPEARANCE_MODES`.

    Examples
    --------
    >>> from scenes import MANIFOLDS, build_world
    >>> world = build_world("lawn")
    >>> world.name, list(world.routes)
    ('lawn', ['lawn-left', 'lawn-straight', 'lawn-right'])
    >>> MANIFOLDS[world.manifold_at([[8.0, 2.0]])[0]]
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
    # Free-space grids already rasterised, per (resolution, inflation). A World compares by
    # value and is mutable, so it is not hashable; the cache lives on the instance instead.
    _free_space: dict = field(default_factory=dict, init=False, repr=False, compare=False)

    @classmethod
    def from_scene(
        cls,
        name: str,
        scene,
        app: Appearance,
        manifolds: ManifoldMap,
        bounds: tuple[float, float, float, float],
        routes: dict[str, Route],
    ) -> World:
        """The finished world of a built :class:`~scenes.mjcf.SceneBuilder` scene."""
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
        )

    def manifold_at(self, xy) -> np.ndarray:
        """Manifold ids at points (..., 2): indices into :data:`scenes.names.MANIFOLDS`, -1 off."""
        return self.manifolds.label_at(xy)

    def free_space(self, resolution: float = 0.05, inflation: float = 0.0) -> OccupancyGrid:
        """Occupancy grid of the walkable floor; ``inflation`` grows obstacles (robot radius)."""
        key = (float(resolution), float(inflation))
        if key not in self._free_space:
            self._free_space[key] = rasterise_free_space(
                self.manifolds, self.footprints, self.bounds, *key
            )
        return self._free_space[key]

    def write(self, directory: str | os.PathLike) -> Path:
        """Write ``<name>.xml`` and its textures, for MuJoCo's own viewer (``simulate``)."""
        directory = Path(directory)
        directory.mkdir(parents=True, exist_ok=True)
        for file, data in self.assets.items():
            atomic_write_bytes(directory / file, data)
        path = directory / f"{self.name}.xml"
        atomic_write_bytes(path, self.xml.encode())
        return path
