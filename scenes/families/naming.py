"""World names: ``"hallway"``, ``"lawn"`` (the canonical worlds) and ``FAMILY:SEED``.

A family is drawn from a seed: ``hallway:17`` is the 17th generated corridor world, ``lawn:3``
the 3rd outdoor one. Seed 0 of each family is its canonical world (``hallway:0`` is
``hallway``), which keeps its hand-built layout and its bytes. Only this module reads or writes
the spelling.
"""

from __future__ import annotations

import re
from dataclasses import dataclass

from scenes import names

__all__ = ["FAMILIES", "MAX_SEED", "WorldName", "check_world_name", "parse_world_name"]

FAMILIES = names.WORLDS  # each canonical world names its family
MAX_SEED = 999_999  # seeds 0 .. MAX_SEED: a million worlds per family
_SPELLING = re.compile(r"([a-z]+)(?::([0-9]+))?\Z")
ACCEPTED = (
    f"'hallway' or 'lawn' (the canonical worlds) or FAMILY:SEED with FAMILY one of {FAMILIES} "
    f"and SEED an integer in [0, {MAX_SEED}] (for example 'hallway:17')"
)


@dataclass(frozen=True, order=True)
class WorldName:
    """A parsed world name.

    Parameters
    ----------
    family : str
        One of `FAMILIES`.
    seed : int
        In ``[0, MAX_SEED]``; 0 is the canonical world.

    Attributes
    ----------
    family : str
        One of `FAMILIES`.
    seed : int
        In ``[0, MAX_SEED]``; 0 is the canonical world.

    Examples
    --------
    >>> from scenes.families.naming import parse_world_name
    >>> parse_world_name("hallway:17")
    WorldName(family='hallway', seed=17)
    >>> str(parse_world_name("lawn:0")), parse_world_name("lawn").canonical
    ('lawn', True)
    """

    family: str
    seed: int

    @property
    def canonical(self) -> bool:
        """Whether this is the hand-built world of its family (seed 0)."""
        return self.seed == 0

    def __str__(self) -> str:
        """Return the name's spelling: ``FAMILY:SEED``, or ``FAMILY`` for seed 0."""
        return self.family if self.canonical else f"{self.family}:{self.seed}"

    @property
    def file_stem(self) -> str:
        """The name with ``:`` replaced by ``-``, for file names (``hallway-17``)."""
        return str(self).replace(":", "-")


def parse_world_name(name) -> WorldName:
    """Parse a world name into its `WorldName`.

    Parameters
    ----------
    name : str or WorldName
        ``"hallway"``, ``"lawn"`` or ``FAMILY:SEED`` (a `WorldName` is returned as is).

    Returns
    -------
    WorldName
        The family and seed.

    Raises
    ------
    ValueError
        Naming the accepted forms, when ``name`` is none of them.
    """
    if isinstance(name, WorldName):
        return name
    match = _SPELLING.match(name) if isinstance(name, str) else None
    if match is None or match.group(1) not in FAMILIES:
        raise ValueError(f"world must be {ACCEPTED}, got {name!r}")
    seed_text = match.group(2)
    if seed_text is None:
        return WorldName(match.group(1), 0)
    if len(seed_text) > len(str(MAX_SEED)) or int(seed_text) > MAX_SEED:
        raise ValueError(f"world must be {ACCEPTED}; the seed of {name!r} is out of range")
    return WorldName(match.group(1), int(seed_text))


def check_world_name(name, argument: str = "world") -> str:
    """Return the normalised spelling of a world name (``"hallway:0"`` -> ``"hallway"``).

    Parameters
    ----------
    name : str or WorldName
        The world name.
    argument : str, default "world"
        What the error message calls ``name``.

    Returns
    -------
    str
        The normalised spelling.

    Raises
    ------
    ValueError
        Naming ``argument`` and the accepted forms, when ``name`` is no world name.
    """
    try:
        return str(parse_world_name(name))
    except ValueError:
        raise ValueError(f"{argument} must be {ACCEPTED}, got {name!r}") from None
