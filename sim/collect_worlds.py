"""The worlds of a collection: their names, sequences, seeding keys and label space.

The canonical worlds keep the paper's layout: three routes each, label ids that index
[`scenes.names.MANIFOLDS`][scenes.names.MANIFOLDS], and sequence seeds 0 to 5. A generated world
(``FAMILY:SEED``, `scenes.families`) records one sequence per route (one per leaf manifold), seeded
by a key that cannot meet a canonical one, and its labels are mapped into the dataset's own list of
manifolds.
"""

from __future__ import annotations

from functools import lru_cache

import numpy as np

from scenes import build_world, names
from scenes.families import check_world_name, parse_world_name

__all__ = [
    "check_worlds",
    "label_lookup",
    "label_space",
    "randomisation_key",
    "sequence_file",
    "world_digest",
    "world_manifold_names",
    "world_sequences",
]

GENERATED_OFFSET = len(names.WORLDS)  # generated keys start past the canonical world indices


def check_worlds(worlds, argument: str = "worlds") -> tuple[str, ...]:
    """The normalised, distinct world names of ``worlds`` (a tuple or list of names); a
    ValueError naming ``argument`` and the accepted forms otherwise.
    """
    if isinstance(worlds, str) or not isinstance(worlds, tuple | list) or not worlds:
        raise ValueError(
            f"{argument} must be a non-empty tuple of world names, each 'hallway', 'lawn' or "
            f"FAMILY:SEED (for example 'hallway:17'); got {worlds!r}"
        )
    out = tuple(check_world_name(w, argument) for w in worlds)
    if len(set(out)) != len(out):
        raise ValueError(f"{argument} must name each world once, got {worlds!r}")
    return out


@lru_cache(maxsize=64)
def world_digest(name: str) -> str:
    """The floor plan's SHA-256 of world ``name`` (`scenes.World.digest`), built once
    per process; ValueError naming the accepted forms for a name that is no world.
    """
    return build_world(check_world_name(name)).digest


@lru_cache(maxsize=64)
def world_manifold_names(name: str) -> tuple[str, ...]:
    """The manifolds of world ``name`` in the order of its label ids (a generated world is
    built once per process to read them).
    """
    world = parse_world_name(name)
    if world.canonical:
        return tuple(m for m in names.MANIFOLDS if m.split("-")[0] == world.family)
    return build_world(str(world)).manifold_names


@lru_cache(maxsize=64)
def _world_route_names(name: str) -> tuple[str, ...]:
    world = parse_world_name(name)
    if world.canonical:
        return tuple(names.manifold_name(world.family, b) for b in names.BRANCHES)
    return tuple(build_world(str(world)).routes)


def world_sequences(name: str) -> list[tuple[int | tuple[int, ...], str, str]]:
    """(seeding index, world, route name) of each route of world ``name``. A canonical world
    keeps its index ``world * 3 + branch``; a generated one gets ``(2 + family, seed,
    route position)``, whose length alone keeps it apart from the canonical ones.
    """
    world = parse_world_name(name)
    if world.canonical:
        w = names.WORLDS.index(world.family)
        return [
            (w * len(names.BRANCHES) + i, str(world), route)
            for i, route in enumerate(_world_route_names(str(world)))
        ]
    family = GENERATED_OFFSET + names.WORLDS.index(world.family)
    return [
        ((family, world.seed, i), str(world), route)
        for i, route in enumerate(_world_route_names(str(world)))
    ]


def sequence_entropy(seed: int, index) -> list[int]:
    """The entropy of a sequence's generators: ``[seed, index]`` for a canonical index (as
    before generated worlds existed), ``[seed, *index]`` for a generated one.
    """
    return [int(seed), *(int(i) for i in np.atleast_1d(index))]


def randomisation_key(name: str, seed: int) -> list[int]:
    """The entropy of world ``name``'s randomised draw for collection seed ``seed``: the
    canonical key ``[seed, 1000 + world index]``; ``[seed, 1000 + 2 + family, world seed]``
    for a generated world.
    """
    world = parse_world_name(name)
    family = names.WORLDS.index(world.family)
    if world.canonical:
        return [int(seed), 1000 + family]
    return [int(seed), 1000 + GENERATED_OFFSET + family, world.seed]


def sequence_file(route: str) -> str:
    """The file of a route's sequence: its name with ``:`` (not allowed there) as ``-``."""
    return route.replace(":", "-") + ".npz"


def label_space(worlds: tuple[str, ...]) -> list[str]:
    """The dataset's manifold names: the paper's 8 when every world is canonical (labels keep
    their ids); else each world's manifolds in turn, in the order of ``worlds``.
    """
    if all(parse_world_name(w).canonical for w in worlds):
        return list(names.MANIFOLDS)
    return [m for w in worlds for m in world_manifold_names(w)]


def label_lookup(worlds: tuple[str, ...], world_ids: dict[str, int], name: str) -> np.ndarray:
    """A table from world ``name``'s label ids (given by ``world_ids``, name -> id) to the
    dataset's: ``table[id]``; the last entry maps -1 (no manifold) to -1.
    """
    space = label_space(worlds)
    table = np.full(max(world_ids.values()) + 2, names.NO_MANIFOLD, np.int16)
    for manifold in world_manifold_names(name):
        table[world_ids[manifold]] = space.index(manifold)  # names are unique across worlds
    return table
