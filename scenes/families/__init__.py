"""Generated worlds: two families drawn from a seed, named ``FAMILY:SEED``.

``hallway:17`` is a world of the indoor family (corridors), ``lawn:3`` one of the outdoor
family (lawns, driveways, paths). Each is a tree of straight stretches joined by bends, T, Y
and X junctions, one to three junctions deep, with lengths, widths and exit angles drawn from
the family's stated ranges (`FAMILY_SPECS`) and every stretch a
manifold with its own look from the family's palette. Seed 0 is the family's canonical world.
[`scenes.build_world`][scenes.registry.build_world] builds any of them; `scenes.families.splits`
says which seeds are for training, tuning and testing.
"""

from scenes.families.build import build_family_world, family_layout
from scenes.families.draw import FAMILY_SPECS, FamilySpec
from scenes.families.layout import Layout
from scenes.families.naming import FAMILIES, MAX_SEED, WorldName, check_world_name, parse_world_name
from scenes.families.splits import (
    REPEATED_TEST_SEEDS,
    SPLITS,
    SPLITS_VERSION,
    held_out_worlds,
    split_of,
    split_worlds,
    structure,
)

__all__ = [
    "FAMILIES",
    "FAMILY_SPECS",
    "MAX_SEED",
    "REPEATED_TEST_SEEDS",
    "SPLITS",
    "SPLITS_VERSION",
    "FamilySpec",
    "Layout",
    "WorldName",
    "build_family_world",
    "check_world_name",
    "family_layout",
    "held_out_worlds",
    "parse_world_name",
    "split_of",
    "split_worlds",
    "structure",
]
