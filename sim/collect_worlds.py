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
    """Check and normalise the distinct world names of ``worlds``.

    Anything but a non-empty tuple or list of distinct world names raises a ValueError naming
    ``argument`` and the accepted forms.

    Parameters
    ----------
    worlds : tuple or list of str
        World names: ``"hallway"``, ``"lawn"`` or ``FAMILY:SEED``.
    argument : str, default "worlds"
        The parameter's name, for the error.

    Returns
    -------
    tuple of str
        The normalised names.
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
    """Return the floor plan's SHA-256 of world ``name`` (`scenes.World.digest`).

    The world is built once per process; a name that is no world raises a ValueError naming
    the accepted forms.

    Parameters
    ----------
    name : str
        The world's name.

    Returns
    -------
    str
        The digest, hex.
    """
    return build_world(check_world_name(name)).digest


@lru_cache(maxsize=64)
def world_manifold_names(name: str) -> tuple[str, ...]:
    """Return the manifolds of world ``name`` in the order of its label ids.

    A generated world is built once per process to read them.

    Parameters
    ----------
    name : str
        The world's name.

    Returns
    -------
    tuple of str
        The manifold names.
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
    """List (seeding index, world, route name) of each route of world ``name``.

    A canonical world keeps its index ``world * 3 + branch``; a generated one gets
    ``(2 + family, seed, route position)``, whose length alone keeps it apart from the
    canonical ones.

    Parameters
    ----------
    name : str
        The world's name.

    Returns
    -------
    list of tuple
        One ``(index, world, route)`` per route.
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
    """Return the entropy of a sequence's generators.

    ``[seed, index]`` for a canonical index (as before generated worlds existed),
    ``[seed, *index]`` for a generated one.

    Parameters
    ----------
    seed : int
        The collection's seed.
    index : int or tuple of int
        The sequence's seeding index.

    Returns
    -------
    list of int
        The entropy for ``numpy.random.default_rng``.
    """
    return [int(seed), *(int(i) for i in np.atleast_1d(index))]


def randomisation_key(name: str, seed: int) -> list[int]:
    """Return the entropy of world ``name``'s randomised draw for collection seed ``seed``.

    The canonical key is ``[seed, 1000 + world index]``; ``[seed, 1000 + 2 + family, world
    seed]`` for a generated world.

    Parameters
    ----------
    name : str
        The world's name.
    seed : int
        The collection's seed.

    Returns
    -------
    list of int
        The entropy for ``numpy.random.default_rng``.
    """
    world = parse_world_name(name)
    family = names.WORLDS.index(world.family)
    if world.canonical:
        return [int(seed), 1000 + family]
    return [int(seed), 1000 + GENERATED_OFFSET + family, world.seed]


def sequence_file(route: str) -> str:
    """Name the file of a route's sequence: its name with ``:`` (not allowed there) as ``-``.

    Parameters
    ----------
    route : str
        The route's name.

    Returns
    -------
    str
        The ``.npz`` file name.
    """
    return route.replace(":", "-") + ".npz"


def label_space(worlds: tuple[str, ...]) -> list[str]:
    """Return the dataset's manifold names.

    The paper's 8 when every world is canonical (labels keep their ids); else each world's
    manifolds in turn, in the order of ``worlds``.

    Parameters
    ----------
    worlds : tuple of str
        The dataset's worlds.

    Returns
    -------
    list of str
        The names; label ``i`` is the ``i``-th.
    """
    if all(parse_world_name(w).canonical for w in worlds):
        return list(names.MANIFOLDS)
    return [m for w in worlds for m in world_manifold_names(w)]


def label_lookup(worlds: tuple[str, ...], world_ids: dict[str, int], name: str) -> np.ndarray:
    """Build a table from world ``name``'s label ids to the dataset's: ``table[id]``.

    The last entry maps -1 (no manifold) to -1.

    Parameters
    ----------
    worlds : tuple of str
        The dataset's worlds.
    world_ids : dict of str to int
        The world's label ids, name -> id.
    name : str
        The world's name.

    Returns
    -------
    ndarray of int16
        The dataset's label of each of the world's ids.
    """
    space = label_space(worlds)
    table = np.full(max(world_ids.values()) + 2, names.NO_MANIFOLD, np.int16)
    for manifold in world_manifold_names(name):
        table[world_ids[manifold]] = space.index(manifold)  # names are unique across worlds
    return table
