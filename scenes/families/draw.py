"""Drawing a floor plan from a seed: the family's ranges, the tree of stretches, the checks.

A family (`FamilySpec`) states the ranges every generated world is drawn from: the
stretches' width and lengths, how deep the tree goes, which junctions it uses and how far apart
their exits must be. `draw_layout` draws one `Layout` from a
``numpy.random.Generator`` and redraws, from the same generator, until the plan passes
`layout_problems` (no two corridors closer than the family's clearance, every junction a
valid polygon), so a seed always gives the same valid plan.

Junctions, as MetaDrive's blocks: a *bend* (2 exits: the corridor turns), a *T* (3 exits: on
through and to one side, or to both sides), a *Y* (3 exits: two forks) and an *X* (4 exits).
Exit angles are drawn around their nominal directions, so right angles are the exception.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from scenes.families.layout import Layout, Stretch

__all__ = ["FAMILY_SPECS", "JUNCTION_KINDS", "FamilySpec", "draw_layout", "layout_problems"]

# kind -> turns of its child exits, degrees, before jitter; None marks a drawn Y fork
JUNCTION_KINDS = ("bend", "T", "Y", "X")
MAX_REDRAWS = 200


@dataclass(frozen=True)
class FamilySpec:
    """The ranges a family's worlds are drawn from (lengths in metres, angles in degrees).

    Parameters
    ----------
    width : (float, float)
        Width of the stretches (one draw per world).
    main_length : (float, float)
        From the main stretch's closed end to its junction's centre.
    branch_length : (float, float)
        From a junction's centre to the next junction's centre or a closed end.
    depth : (int, int)
        Junctions from the main stretch to the deepest leaf, inclusive range.
    kinds : dict
        Weight of each of `JUNCTION_KINDS`.
    jitter : float
        Largest deviation of an exit from its nominal direction.
    min_gap : float
        Smallest angle between two exits of one junction.
    max_manifolds : int
        Most stretches in one world.
    more_junctions : float
        Chance that a stretch off the deepest path ends in a junction too (depth permitting).
    clearance : float
        Least distance between two pieces of floor that do not meet (walls, fences and the
        buildings behind them stand in between).
    route_start, route_end_margin, turn_in : float
        The teleop routes' (see `Layout`).
    """

    width: tuple[float, float]
    main_length: tuple[float, float]
    branch_length: tuple[float, float]
    depth: tuple[int, int] = (1, 3)
    kinds: tuple[tuple[str, float], ...] = (("bend", 0.2), ("T", 0.3), ("Y", 0.2), ("X", 0.3))
    jitter: float = 20.0
    min_gap: float = 45.0
    max_manifolds: int = 12
    more_junctions: float = 0.35
    clearance: float = 1.0
    route_start: float = 1.0
    route_end_margin: float = 0.8
    turn_in: float = 1.0


FAMILY_SPECS = {
    # corridors: the canonical hallway is 2.4 m wide, 17.2 m to its junction, 17.2 m arms
    "hallway": FamilySpec(
        width=(2.0, 3.2), main_length=(10.0, 20.0), branch_length=(8.0, 18.0), clearance=0.8
    ),
    # lawns, driveways and paths: fences, hedges and houses between them
    "lawn": FamilySpec(
        width=(5.0, 8.0),
        main_length=(12.0, 22.0),
        branch_length=(11.0, 20.0),
        clearance=6.0,
        route_start=1.5,
        route_end_margin=1.5,
        turn_in=1.5,
    ),
}


def _child_turns(kind: str, rng: np.random.Generator, spec: FamilySpec) -> list[float]:
    """Draw the turns of a junction's children from the arriving heading, rad, right to left."""
    j = spec.jitter
    if kind == "bend":
        turns = [rng.choice([-1.0, 1.0]) * rng.uniform(35.0, 180.0 - spec.min_gap)]
    elif kind == "T":
        if rng.random() < 0.5:  # on through, and off to one side
            turns = [rng.uniform(-j, j), rng.choice([-1.0, 1.0]) * rng.uniform(90 - j, 90 + j)]
        else:  # the bar of the T: off to both sides
            turns = [-rng.uniform(90 - j, 90 + j), rng.uniform(90 - j, 90 + j)]
    elif kind == "Y":
        turns = [-rng.uniform(25.0, 70.0), rng.uniform(25.0, 70.0)]
    elif kind == "X":
        turns = [-90.0 + rng.uniform(-j, j), rng.uniform(-j, j), 90.0 + rng.uniform(-j, j)]
    else:
        raise ValueError(f"kind must be one of {JUNCTION_KINDS}, got {kind!r}")
    return [float(np.deg2rad(t)) for t in sorted(turns)]


def branch_names(turns: list[float]) -> list[str]:
    """Name a junction's children, right to left.

    The names are ``right``/``straight``/``left`` by the turn where one child is within 20
    degrees of straight on, else by rank.

    Parameters
    ----------
    turns : list of float
        The children's turns from the arriving heading, rad, right to left.

    Returns
    -------
    list of str
        One name per child.
    """
    if len(turns) == 3:
        return ["right", "straight", "left"]
    ahead = [abs(np.rad2deg(t)) < 20.0 for t in turns]
    if len(turns) == 1:
        return ["straight" if ahead[0] else ("left" if turns[0] > 0 else "right")]
    if ahead[0]:
        return ["straight", "left"]
    if ahead[1]:
        return ["right", "straight"]
    return ["right", "left"]


def _gaps_ok(turns: list[float], min_gap: float) -> bool:
    angles = np.sort(np.mod([np.pi, *turns], 2 * np.pi))
    gaps = np.diff(np.concatenate([angles, [angles[0] + 2 * np.pi]]))
    return bool(gaps.min() >= np.deg2rad(min_gap) - 1e-9)


def _draw_tree(rng: np.random.Generator, spec: FamilySpec, world: str) -> Layout:
    weights = np.array([w for _, w in spec.kinds], float)
    kinds = [k for k, _ in spec.kinds]
    depth = int(rng.integers(spec.depth[0], spec.depth[1] + 1))
    half_width = float(rng.uniform(*spec.width)) / 2.0
    stretches = [Stretch(world, "", None, (0.0, 0.0), 0.0, float(rng.uniform(*spec.main_length)))]
    # (stretch index, its junction's level, whether it lies on the path to the deepest leaf)
    todo = [(0, 1, True)]
    while todo:
        parent, level, deepest = todo.pop(0)
        kind = kinds[int(rng.choice(len(kinds), p=weights / weights.sum()))]
        turns = _child_turns(kind, rng, spec)
        while not _gaps_ok(turns, spec.min_gap):
            turns = _child_turns(kind, rng, spec)
        room = spec.max_manifolds - len(stretches)
        if room <= 0:  # no manifold left for this junction: the stretch ends closed
            continue
        turns = turns[:room]
        go_on = int(rng.integers(len(turns)))  # the child that carries the deepest path
        p = stretches[parent]
        for k, (turn, name) in enumerate(zip(turns, branch_names(turns), strict=True)):
            branch = f"{p.branch}-{name}" if p.branch else name
            index = len(stretches)
            stretches.append(
                Stretch(
                    f"{world}-{branch}",
                    branch,
                    parent,
                    tuple(float(v) for v in p.end),
                    float(p.heading + turn),
                    float(rng.uniform(*spec.branch_length)),
                )
            )
            more = (deepest and k == go_on) or rng.random() < spec.more_junctions
            if level < depth and more:
                todo.append((index, level + 1, deepest and k == go_on))
    return Layout(
        tuple(stretches), half_width, spec.route_start, spec.route_end_margin, spec.turn_in
    )


def layout_problems(layout: Layout, clearance: float) -> list[str]:
    """List what makes a floor plan unbuildable; empty when it is sound.

    Every piece of floor (a stretch's rectangle, a junction's hub) must be a valid polygon
    with area; pieces that meet at a junction must not overlap; any other two must lie at
    least ``clearance`` apart; every stretch must keep some corridor between its two mouths.

    Parameters
    ----------
    layout : Layout
        The floor plan.
    clearance : float
        Least distance between two pieces that do not meet, m.

    Returns
    -------
    list of str
        One line per problem.
    """
    from shapely.geometry import Polygon

    problems = []
    for i in range(len(layout.stretches)):
        s0, s1 = layout.extent(i)
        if s1 - s0 < 2.0:
            problems.append(f"stretch {i} has {s1 - s0:.2f} m between its mouths")
    pieces = [(name, Polygon(p)) for name, p in layout.pieces()]
    for name, poly in pieces:
        if not poly.is_valid or poly.area <= 1e-6:
            problems.append(f"{name} is not a valid polygon")
    if problems:
        return problems
    meets = _meeting_pieces(layout)
    for a in range(len(pieces)):
        for b in range(a + 1, len(pieces)):
            (na, pa), (nb, pb) = pieces[a], pieces[b]
            if (na, nb) in meets:
                if pa.intersection(pb).area > 1e-6:
                    problems.append(f"{na} overlaps {nb}")
            elif pa.distance(pb) < clearance:
                problems.append(f"{na} and {nb} are {pa.distance(pb):.2f} m apart")
    return problems


def _meeting_pieces(layout: Layout) -> set[tuple[str, str]]:
    """Pairs of piece names that share a junction (they may touch)."""
    at: dict[str, set[int]] = {}
    for owner, j in layout.junctions.items():
        for s, _ in j.exits:
            at.setdefault(f"stretch:{s}", set()).add(owner)
        at.setdefault(f"hub:{owner}", set()).add(owner)
    names = [n for n, _ in layout.pieces()]
    return {(a, b) for a in names for b in names if a != b and at.get(a, set()) & at.get(b, set())}


def draw_layout(family: str, rng: np.random.Generator, world: str) -> Layout:
    """Draw a sound floor plan of ``family`` from ``rng``, its main manifold named ``world``.

    Parameters
    ----------
    family : str
        One of the families of `FAMILY_SPECS`.
    rng : numpy.random.Generator
        The generator of the draw.
    world : str
        The world's name, the main manifold's name.

    Returns
    -------
    Layout
        The floor plan.

    Raises
    ------
    RuntimeError
        If no sound plan was drawn in `MAX_REDRAWS` tries (never seen on the tested
        seeds; the message names the family and the last problem).
    """
    spec = FAMILY_SPECS[family]
    problems: list[str] = []
    for _ in range(MAX_REDRAWS):
        layout = _draw_tree(rng, spec, world)
        problems = layout_problems(layout, spec.clearance)
        if not problems:
            return layout
    raise RuntimeError(f"no sound {family} layout in {MAX_REDRAWS} draws: {problems[0]}")
