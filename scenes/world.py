"""A built world: its MJCF, texture assets and ground truth (manifolds, free space, routes)."""

from __future__ import annotations

import os
from dataclasses import dataclass, field
from functools import lru_cache
from pathlib import Path

import numpy as np

from scenes import names
from scenes.fileio import atomic_write_bytes
from scenes.regions import Footprint, ManifoldMap, OccupancyGrid, Route, rasterise_free_space

# Domain randomisation table, as Miniworld's params: name -> (default, low, high). Without an
# RNG every parameter takes its default, so the canonical world is one fixed scene.
RANDOMIZATION: dict[str, tuple[float, float, float]] = {
    "light_intensity": (1.0, 0.55, 1.45),  # multiplier on every light's diffuse colour
    "light_tint": (0.0, -0.12, 0.12),  # per-channel shift of light colour
    "light_shift": (0.0, -0.6, 0.6),  # m, light positions along the corridor / sun direction
    "colour_jitter": (0.0, -0.08, 0.08),  # per-channel shift of every base texture colour
    "clutter_shift": (0.0, -0.5, 0.5),  # m, furniture and posters slid along their wall
}
TEXTURE_SEED = 20_040_607  # canonical textures: fixed noise, part of the world's identity
# How the manifolds of a world differ in look. "default": each branch has its own wall, floor
# and light colour (a colour histogram tells them apart). "hard": every branch shares the main
# manifold's wall, floor (ground) and light materials, so only the layout (branch directions,
# lengths, furniture and landmarks) tells them apart (issue 13, item 5).
APPEARANCE_MODES = ("default", "hard")


@dataclass(frozen=True)
class Appearance:
    """One draw from :data:`RANDOMIZATION` plus the generator that made the textures, and the
    appearance mode (one of :data:`APPEARANCE_MODES`)."""

    params: dict
    texture_rng: np.random.Generator = field(compare=False, repr=False)
    rng: np.random.Generator | None = field(compare=False, repr=False, default=None)
    mode: str = "default"

    @property
    def shared_materials(self) -> bool:
        """Whether every branch wears the main manifold's wall, floor and light materials."""
        return self.mode == "hard"

    def __getitem__(self, key: str) -> float:
        return self.params[key]

    def colour(self, rgb) -> tuple[float, float, float]:
        """A base colour with this draw's jitter (a new jitter per call when randomised)."""
        rgb = np.asarray(rgb, np.float64)
        if self.rng is not None:
            lo, hi = RANDOMIZATION["colour_jitter"][1:]
            rgb = rgb + self.rng.uniform(lo, hi, 3)
        return tuple(np.clip(rgb, 0.0, 1.0))

    def light(self, rgb) -> tuple[float, float, float]:
        tint = (
            np.zeros(3)
            if self.rng is None
            else self.rng.uniform(*RANDOMIZATION["light_tint"][1:], 3)
        )
        return tuple(np.clip(np.asarray(rgb) * self["light_intensity"] + tint, 0.0, 1.0))

    def shift(self, key: str) -> float:
        """A fresh draw of a positional parameter (0 when not randomised)."""
        if self.rng is None:
            return RANDOMIZATION[key][0]
        return float(self.rng.uniform(*RANDOMIZATION[key][1:]))


def check_appearance_mode(mode) -> str:
    """``mode`` if it is one of :data:`APPEARANCE_MODES`, else a ValueError naming them."""
    if not isinstance(mode, str) or mode not in APPEARANCE_MODES:
        raise ValueError(f"appearance must be one of {APPEARANCE_MODES}, got {mode!r}")
    return mode


def draw_appearance(rng: np.random.Generator | None, mode: str = "default") -> Appearance:
    """Defaults and canonical textures without an RNG; a randomised draw with one. ``mode``
    only changes which materials the builders assign, never what the generators draw, so a
    hard world has the same textures, lights and clutter draws as its default twin."""
    mode = check_appearance_mode(mode)
    if rng is None:
        params = {k: v[0] for k, v in RANDOMIZATION.items()}
        return Appearance(params, np.random.default_rng(TEXTURE_SEED), None, mode)
    if not isinstance(rng, np.random.Generator):
        raise TypeError(f"rng must be a numpy.random.Generator or None, got {type(rng).__name__}")
    params = {k: float(rng.uniform(lo, hi)) for k, (_, lo, hi) in RANDOMIZATION.items()}
    texture_rng, layout_rng = rng.spawn(2)
    return Appearance(params, texture_rng, layout_rng, mode)


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
        return _free_space_cached(self, float(resolution), float(inflation))

    def write(self, directory: str | os.PathLike) -> Path:
        """Write ``<name>.xml`` and its textures, for MuJoCo's own viewer (``simulate``)."""
        directory = Path(directory)
        directory.mkdir(parents=True, exist_ok=True)
        for file, data in self.assets.items():
            atomic_write_bytes(directory / file, data)
        path = directory / f"{self.name}.xml"
        atomic_write_bytes(path, self.xml.encode())
        return path

    def __hash__(self) -> int:
        return id(self)


@lru_cache(maxsize=16)
def _free_space_cached(world: World, resolution: float, inflation: float) -> OccupancyGrid:
    return rasterise_free_space(
        world.manifolds, world.footprints, world.bounds, resolution, inflation
    )


def build_world(
    name: str, rng: np.random.Generator | None = None, appearance: str = "default"
) -> World:
    """Build a world by name.

    Parameters
    ----------
    name : {"hallway", "lawn"}
    rng : numpy.random.Generator, optional
        Without one, the canonical world (fixed textures, default lights and clutter). With one,
        a domain-randomised variant (textures, colours, lighting, clutter placement), the same
        for the same generator state.
    appearance : {"default", "hard"}
        ``"hard"``: every branch shares the main manifold's wall, floor and light materials
        (see :data:`APPEARANCE_MODES`); the geometry is that of the default world.
    """
    if name not in names.WORLDS:
        raise ValueError(f"world must be one of {names.WORLDS}, got {name!r}")
    appearance = draw_appearance(rng, appearance)
    if name == names.HALLWAY:
        from scenes.hallway import build_hallway

        return build_hallway(appearance)
    from scenes.lawn import build_lawn

    return build_lawn(appearance)
