"""Frozen splits of each family's seeds: train, dev and test worlds.

Methods are built and tuned on ``train`` and ``dev`` worlds; their numbers are reported on
``test`` worlds, scored once per release. The ranges are frozen: changing them, or the
generator, makes every held-out number incomparable (the version below says which).

Two worlds can differ only below what a method could tell apart (a few centimetres of
length, a degree of angle). `structure` quantises a floor plan, and
`held_out_worlds` skips test seeds whose structure also occurs among the train seeds
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
# test seed -> the first train seed of the same structure, per family: written from
# ``python -m scripts.world_splits`` (docs/results/data/worlds/splits.json)
REPEATED_TEST_SEEDS = {
    "hallway": {
        11009: 4091,
        11047: 5158,
        11087: 238,
        11095: 3255,
        11102: 4493,
        11103: 6000,
        11128: 8714,
        11137: 5163,
        11141: 2773,
        11160: 490,
        11211: 4360,
        11232: 1086,
        11234: 118,
        11269: 9969,
        11286: 3020,
        11302: 2370,
        11338: 5606,
        11340: 3484,
        11368: 6165,
        11395: 1877,
        11414: 330,
        11451: 1513,
        11479: 9632,
        11497: 1432,
        11498: 5106,
        11530: 490,
        11538: 4164,
        11592: 7494,
        11665: 9948,
        11719: 1604,
        11740: 4140,
        11813: 5387,
        11819: 4165,
        11832: 2211,
        11925: 1767,
        11947: 842,
        11954: 6899,
        11967: 3634,
        11977: 6855,
        11986: 9110,
        11995: 8089,
    },
    "lawn": {
        11000: 2608,
        11005: 6020,
        11017: 8049,
        11018: 5899,
        11023: 5960,
        11027: 228,
        11034: 5925,
        11050: 4308,
        11077: 2269,
        11084: 5697,
        11104: 4572,
        11119: 967,
        11124: 7928,
        11141: 53,
        11148: 7592,
        11161: 3756,
        11201: 8696,
        11202: 5016,
        11211: 4732,
        11219: 2627,
        11221: 3857,
        11257: 36,
        11262: 2925,
        11263: 9767,
        11271: 2287,
        11272: 7953,
        11276: 5010,
        11284: 1369,
        11292: 7658,
        11307: 370,
        11324: 6146,
        11336: 3960,
        11382: 4361,
        11393: 2990,
        11419: 9642,
        11423: 1659,
        11463: 9908,
        11477: 2328,
        11507: 135,
        11537: 2353,
        11561: 9541,
        11566: 7241,
        11579: 1558,
        11615: 5422,
        11629: 8641,
        11630: 2271,
        11675: 7623,
        11682: 7623,
        11711: 338,
        11749: 696,
        11774: 8128,
        11794: 1443,
        11798: 2627,
        11834: 2537,
        11843: 109,
        11850: 1117,
        11863: 5511,
        11865: 1849,
        11880: 9057,
        11919: 1008,
        11922: 4995,
        11924: 8648,
        11927: 3880,
        11942: 1309,
        11945: 5064,
        11978: 547,
    },
}


def split_of(name) -> str | None:
    """Return the split of a world (``"train"``, ``"dev"``, ``"test"``), None past the ranges.

    Parameters
    ----------
    name : str or WorldName
        The world's name.

    Returns
    -------
    str or None
        The split its seed lies in.

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
    """Return the names of ``split``'s worlds of ``family``, in seed order.

    The canonical world (seed 0) is not listed: it is built by hand, not drawn.

    Parameters
    ----------
    family : str
        One of `FAMILIES`.
    split : str
        One of `SPLITS` (``"train"``, ``"dev"``, ``"test"``).
    count : int or None, default None
        List the first ``count`` only; None: all of them.

    Returns
    -------
    list of str
        ``FAMILY:SEED`` names.
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
    """Quantise a floor plan to what tells two worlds apart.

    That is, per stretch, its branch, its turn from its parent (15 degree steps) and its length
    (2 m steps), and the width (0.4 m steps). Equal structures are one world for the methods;
    different ones are not.

    Parameters
    ----------
    layout : Layout
        The floor plan.

    Returns
    -------
    tuple
        The quantised width, then ``(branch, turn, length)`` per stretch.
    """
    out = [round(2 * layout.half_width / WIDTH_STEP)]
    for s in layout.stretches:
        parent = 0.0 if s.parent is None else layout.stretches[s.parent].heading
        turn = np.rad2deg((s.heading - parent + np.pi) % (2 * np.pi) - np.pi)
        out.append((s.branch, round(turn / ANGLE_STEP), round(s.length / LENGTH_STEP)))
    return tuple(out)


def held_out_worlds(family: str, count: int, train_structures: set | None = None) -> list[str]:
    """Return the first ``count`` test worlds of ``family`` whose structure is no training world's.

    Those listed in `REPEATED_TEST_SEEDS` are skipped, or, given ``train_structures``, those
    whose structure is in it.

    Parameters
    ----------
    family : str
        One of `FAMILIES`.
    count : int
        Number of worlds.
    train_structures : set or None, default None
        A set of `structure`; None: skip `REPEATED_TEST_SEEDS` instead.

    Returns
    -------
    list of str
        ``FAMILY:SEED`` names, in seed order.

    Raises
    ------
    ValueError
        When the test split has fewer than ``count`` such worlds.
    """
    from scenes.families.build import family_layout

    repeated = REPEATED_TEST_SEEDS[family] if train_structures is None else {}
    out = []
    for name in split_worlds(family, "test"):
        if len(out) == count:
            break
        seed = int(name.split(":")[1])
        if train_structures is not None:
            if structure(family_layout(name)) not in train_structures:
                out.append(name)
        elif seed not in repeated:
            out.append(name)
    if len(out) < count:
        raise ValueError(f"count must be at most {len(out)} for {family}'s test worlds")
    return out
