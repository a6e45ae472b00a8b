"""Frozen splits of each family's seeds: train, dev and test worlds.

Methods are built and tuned on ``train`` and ``dev`` worlds; their numbers are reported on
``test`` worlds, scored once per release. The ranges are frozen: changing them, or the
generator, makes every held-out number incomparable (the version below says which).

Two worlds can differ only below what a method could tell apart (a few centimetres of
length, a degree of angle). :func:`structure` quantises a floor plan, and
:func:`held_out_worlds` skips test seeds whose structure also occurs among the train seeds
(Procgen's mazes repeated 20% of their test levels in training);
``python -m scripts.world_splits`` counts them over the whole train range.
"""

from __future__ import annotations

import numpy as np

from scenes.families.layout import Layout
from scenes.families.naming import FAMILIES, WorldName

__all__ = [
    "SPLITS",
    "SPLITS_VERSION",
    "held_out_worlds",
    "split_of",
    "split_worlds",
    "structure",
]

SPLITS_VERSION = 1  # the ranges below and the generator they draw from
# split -> (first seed, last seed), the same for every family; seed 0 is the canonical world,
# which the methods were built on: it is a training world
SPLITS = {"train": (0, 9_999), "dev": (10_000, 10_999), "test": (11_000, 11_999)}
ANGLE_STEP = 15.0  # degrees: turns closer than this are one structure
LENGTH_STEP = 2.0  # metres: stretches closer than this are one structure
WIDTH_STEP = 0.4  # metres


def split_of(name) -> str | None:
    """The split of a world (``"train"``, ``"dev"``, ``"test"``), None past the ranges.

    Examples
    --------
    >>> from scenes.families.splits import split_of
    >>> split_of("hallway"), split_of("lawn:10500"), split_of("hallway:11000")
    ('train', 'dev', 'test')
    """
    from scenes.families.naming import parse_world_name

    seed = parse_world_name(name).seed
    return next((s for s, (a, b) in SPLITS.items() if a <= seed <= b), None)


def split_worlds(family: str, split: str, count: int | None = None) -> list[str]:
    """The names of ``split``'s worlds of ``family``, in seed order (the first ``count``).

    The canonical world (seed 0) is not listed: it is built by hand, not drawn.
    """
    if family not in FAMILIES:
        raise ValueError(f"family must be one of {FAMILIES}, got {family!r}")
    if split not in SPLITS:
        raise ValueError(f"split must be one of {tuple(SPLITS)}, got {split!r}")
    first, last = SPLITS[split]
    first = max(first, 1)
    n = last - first + 1 if count is None else count
    if not isinstance(n, int) or not 0 <= n <= last - first + 1:
        raise ValueError(f"count must be an integer in [0, {last - first + 1}], got {count!r}")
    return [str(WorldName(family, s)) for s in range(first, first + n)]


def structure(layout: Layout) -> tuple:
    """A floor plan quantised to what tells two worlds apart: per stretch its branch, its
    turn from its parent (15 degree steps) and its length (2 m steps), and the width (0.4 m
    steps). Equal structures are one world for the methods; different ones are not."""
    out = [round(2 * layout.half_width / WIDTH_STEP)]
    for s in layout.stretches:
        parent = 0.0 if s.parent is None else layout.stretches[s.parent].heading
        turn = np.rad2deg((s.heading - parent + np.pi) % (2 * np.pi) - np.pi)
        out.append((s.branch, round(turn / ANGLE_STEP), round(s.length / LENGTH_STEP)))
    return tuple(out)


def held_out_worlds(family: str, count: int, train_structures: set | None = None) -> list[str]:
    """The first ``count`` test worlds of ``family`` whose structure is not a training
    world's. ``train_structures``: the set of :func:`structure` over the train seeds (slow to
    make: ``python -m scripts.world_splits`` computes it); without it no test seed is skipped."""
    from scenes.families.build import family_layout

    out = []
    for name in split_worlds(family, "test"):
        if len(out) == count:
            break
        if train_structures is None or structure(family_layout(name)) not in train_structures:
            out.append(name)
    if len(out) < count:
        raise ValueError(f"count must be at most {len(out)} for {family}'s test worlds")
    return out
