"""The floor plan of a generated world: a tree of straight stretches joined by junctions.

A `Layout` holds the stretches (one manifold each), drawn by `scenes.families.draw`,
and computes everything geometric from them: the hub polygon of every junction, each stretch's
rectangle of floor, the manifold regions (a stretch's rectangle plus its sector of each hub it
meets), the walls along the free space's boundary and one teleop route per leaf. Nothing here
draws random numbers or knows materials: the same layout gives the same geometry.

Junction geometry, for exits ``i`` (unit direction ``u_i``, left normal ``n_i``) sorted
counter-clockwise around the centre ``c``, all of half-width ``h``: the left wall of exit ``i``
(``n_i . p = h``) meets the right wall of the next exit ``j`` (``n_j . p = -h``) at the corner
``K_ij = c + h (n_i - n_j) / (1 - cos D)``, ``D`` the angle from ``u_i`` to ``u_j``. Exit ``i``'s
corridor starts where both its corners lie behind it: ``d_i = max(0, h cot(D_left / 2),
h cot(D_right / 2))``. A corner with ``D < pi`` is an inner corner (the solid between two
corridors), one with ``D > pi`` an outer corner (the outside of a bend).
"""

from __future__ import annotations

from dataclasses import dataclass
from functools import cached_property
from itertools import pairwise

import numpy as np

from scenes.regions import Region, Route

__all__ = ["Junction", "Layout", "Stretch", "Wall"]

_EPS = 1e-9


def _unit(angle: float) -> np.ndarray:
    return np.array([np.cos(angle), np.sin(angle)])


def _left(angle: float) -> np.ndarray:
    return np.array([-np.sin(angle), np.cos(angle)])


@dataclass(frozen=True)
class Stretch:
    """One straight stretch of floor, and one manifold.

    Parameters
    ----------
    name : str
        The manifold's name.
    branch : str
        The turns from the main stretch (``"left-straight"``); ``""`` for the main stretch.
    parent : int or None
        Index of the stretch it leaves from (None for the main stretch).
    start : tuple of float
        Where its centre line starts: the parent's junction centre (or the main stretch's
        closed end), metres.
    heading : float
        Direction of its centre line, radians.
    length : float
        From ``start`` to its end: the next junction's centre or its closed end, metres.
    """

    name: str
    branch: str
    parent: int | None
    start: tuple[float, float]
    heading: float
    length: float

    @property
    def end(self) -> np.ndarray:
        """Where its centre line ends: ``start`` plus ``length`` along ``heading``, m."""
        return np.asarray(self.start) + self.length * _unit(self.heading)


@dataclass(frozen=True)
class Junction:
    """Where a stretch ends and its children start.

    Made by `junction`; the parameters are the attributes below.

    Parameters
    ----------
    centre, exits, corners, gaps, mouths
        As the attributes.

    Attributes
    ----------
    centre : ndarray (2,)
        The junction's centre, m.
    exits : tuple of (stretch index, direction)
        Counter-clockwise; the direction of the stretch that arrives is its heading plus pi.
    corners : ndarray (k, 2)
        ``corners[i]`` joins exit ``i``'s left wall to exit ``i + 1``'s right wall.
    gaps : ndarray (k,)
        The angle from exit ``i`` to exit ``i + 1``, radians.
    mouths : ndarray (k,)
        How far from the centre each exit's corridor starts, metres.
    """

    centre: np.ndarray
    exits: tuple[tuple[int, float], ...]
    corners: np.ndarray
    gaps: np.ndarray
    mouths: np.ndarray

    def sector(self, i: int, half_width: float) -> np.ndarray:
        """Return the part of the hub that belongs to exit ``i``.

        A robot is on that exit's manifold once it has crossed the centre toward it (the
        canonical worlds split their junction square by its diagonals for the same reason).

        Parameters
        ----------
        i : int
            Index of the exit in ``exits``.
        half_width : float
            Half the corridors' width, m.

        Returns
        -------
        ndarray of shape (m, 2)
            The sector's polygon, m.
        """
        k = len(self.exits)
        direction = self.exits[i][1]
        u, n = _unit(direction), _left(direction)
        mouth = self.centre + self.mouths[i] * u
        ring = [self.centre, self.corners[(i - 1) % k], mouth - half_width * n]
        return _simplify(np.array(ring + [mouth + half_width * n, self.corners[i]]))

    def polygon(self, half_width: float) -> np.ndarray:
        """Return the hub: every exit's sector together, counter-clockwise.

        Parameters
        ----------
        half_width : float
            Half the corridors' width, m.

        Returns
        -------
        ndarray of shape (m, 2)
            The hub's polygon, m.
        """
        points = []
        for i, (_, direction) in enumerate(self.exits):
            u, n = _unit(direction), _left(direction)
            mouth = self.centre + self.mouths[i] * u
            points += [mouth - half_width * n, mouth + half_width * n, self.corners[i]]
        return _simplify(np.array(points))


def _simplify(ring: np.ndarray) -> np.ndarray:
    """Return ``ring`` without repeated points and without vertices on a straight line.

    A vertex on a straight line between its neighbours (a bend's centre lies on its sectors'
    edge) is dropped: rounding there would make the polygon cross itself by a hair.
    """
    ring = ring[np.linalg.norm(ring - np.roll(ring, 1, axis=0), axis=1) > 1e-7]
    while len(ring) > 3:
        prev, nxt = np.roll(ring, 1, axis=0), np.roll(ring, -1, axis=0)
        a, b = ring - prev, nxt - ring
        cross = np.abs(a[:, 0] * b[:, 1] - a[:, 1] * b[:, 0])
        flat = cross < 1e-9 * np.linalg.norm(a, axis=1) * np.linalg.norm(b, axis=1) + 1e-12
        if not flat.any():
            break
        ring = np.delete(ring, int(np.argmax(flat)), axis=0)
    return ring


def junction(centre, exits: list[tuple[int, float]], half_width: float) -> Junction:
    """Compute the hub geometry of one junction (see the module docstring).

    Parameters
    ----------
    centre : array_like of shape (2,)
        The junction's centre, m.
    exits : list of (int, float)
        Each exit's stretch index and direction, rad (in any order).
    half_width : float
        Half the corridors' width, m.

    Returns
    -------
    Junction
        The hub, its exits sorted counter-clockwise.
    """
    exits = sorted(exits, key=lambda e: e[1] % (2 * np.pi))
    k = len(exits)
    c = np.asarray(centre, np.float64)
    angles = np.array([e[1] for e in exits])
    gaps = (np.roll(angles, -1) - angles) % (2 * np.pi)
    if k == 1:
        gaps = np.array([2 * np.pi])
    corners = np.zeros((k, 2))
    for i in range(k):
        j = (i + 1) % k
        d = gaps[i]
        corners[i] = c + half_width * (_left(angles[i]) - _left(angles[j])) / (1.0 - np.cos(d))
    cot = np.cos(gaps / 2) / np.sin(gaps / 2)
    mouths = np.maximum(0.0, half_width * np.maximum(cot, np.roll(cot, 1)))
    return Junction(c, tuple((int(s), float(a)) for s, a in exits), corners, gaps, mouths)


@dataclass(frozen=True)
class Wall:
    """A straight piece of the free space's boundary.

    ``a`` to ``b`` runs with the free space on its left; ``extend`` and ``trim`` say by how much
    a solid of thickness 1 along it must grow past (outer corner) or stop short of (inner
    corner sharper than a right angle) each end so that walls meet without a gap and without
    poking into a neighbouring corridor; multiply by the thickness.

    Parameters
    ----------
    a, b : tuple of float
        The wall's ends, m, the free space on its left from ``a`` to ``b``.
    stretch : int
        Index of the stretch it bounds.
    kind : {"side", "end"}
        A stretch's side or its closed end.
    start_shift, end_shift : float, default 0.0
        Per metre of thickness: > 0 extends past ``a`` (``b``), < 0 stops short of it.
    """

    a: tuple[float, float]
    b: tuple[float, float]
    stretch: int
    kind: str  # "side" or "end"
    start_shift: float = 0.0  # > 0 extends past a, < 0 stops short of it (per metre of thickness)
    end_shift: float = 0.0

    @property
    def length(self) -> float:
        """The distance from ``a`` to ``b``, m."""
        return float(np.hypot(self.b[0] - self.a[0], self.b[1] - self.a[1]))

    def box(self, thickness: float) -> tuple[np.ndarray, float, float]:
        """Return the box of a solid of ``thickness`` just outside the wall.

        Parameters
        ----------
        thickness : float
            The solid's thickness, m.

        Returns
        -------
        centre : ndarray of shape (2,)
            Its centre, m.
        half_length : float
            Half its length, m (with the shifts at both ends).
        yaw : float
            Its direction, rad.
        """
        a, b = np.asarray(self.a), np.asarray(self.b)
        direction = (b - a) / max(self.length, _EPS)
        outward = np.array([direction[1], -direction[0]])  # the free space is on the left
        a = a - self.start_shift * thickness * direction
        b = b + self.end_shift * thickness * direction
        centre = (a + b) / 2 + outward * thickness / 2
        return centre, float(np.linalg.norm(b - a) / 2), float(np.arctan2(*direction[::-1]))


def _corner_shift(gap: float) -> float:
    """Return the shift of a wall's end at a corner, per metre of wall thickness.

    Extend past an outer corner; stop short of an inner corner sharper than a right angle (its
    solid wedge is narrower than the wall is thick).
    """
    if gap > np.pi + 1e-6:
        return 1.0
    if gap < np.pi / 2:
        return -1.0 / np.tan(gap)
    return 0.0


@dataclass(frozen=True)
class Layout:
    """The floor plan of a generated world.

    Parameters
    ----------
    stretches : tuple of Stretch
        The main stretch first, then depth first; index = position.
    half_width : float
        Half the width of every stretch, metres.
    route_start : float
        Where the teleop routes start along the main stretch, metres from its closed end.
    route_end_margin : float
        How far short of a closed end the routes stop, metres.
    turn_in : float
        The routes pass this far before and after each junction's centre, metres.
    """

    stretches: tuple[Stretch, ...]
    half_width: float
    route_start: float = 1.0
    route_end_margin: float = 0.8
    turn_in: float = 1.0

    # -- tree -------------------------------------------------------------------------------
    @cached_property
    def children(self) -> dict[int, list[int]]:
        """The indices of each stretch's children, by stretch."""
        out: dict[int, list[int]] = {i: [] for i in range(len(self.stretches))}
        for i, s in enumerate(self.stretches):
            if s.parent is not None:
                out[s.parent].append(i)
        return out

    def leaves(self) -> list[int]:
        """Return the stretches without children: those that end closed.

        Returns
        -------
        list of int
            Their indices.
        """
        return [i for i, c in self.children.items() if not c]

    def path(self, i: int) -> list[int]:
        """Return the stretch indices from the main stretch to ``i``.

        Parameters
        ----------
        i : int
            Index of a stretch.

        Returns
        -------
        list of int
            The indices, the main stretch's (0) first and ``i`` last.
        """
        out = [i]
        while self.stretches[out[-1]].parent is not None:
            out.append(self.stretches[out[-1]].parent)
        return out[::-1]

    @property
    def depth(self) -> int:
        """Junctions on the longest path from the main stretch to a leaf."""
        return max(len(self.path(i)) - 1 for i in self.leaves())

    # -- geometry ---------------------------------------------------------------------------
    @cached_property
    def junctions(self) -> dict[int, Junction]:
        """The junction at the end of each stretch that has children, by that stretch."""
        out = {}
        for i, kids in self.children.items():
            if not kids:
                continue
            s = self.stretches[i]
            exits = [(i, s.heading + np.pi)] + [(k, self.stretches[k].heading) for k in kids]
            out[i] = junction(s.end, exits, self.half_width)
        return out

    def _exit_index(self, j: Junction, stretch: int) -> int:
        return next(k for k, (s, _) in enumerate(j.exits) if s == stretch)

    def extent(self, i: int) -> tuple[float, float]:
        """Return where stretch ``i``'s rectangle starts and ends along its centre line.

        Parameters
        ----------
        i : int
            Index of a stretch.

        Returns
        -------
        s0, s1 : float
            The distances from the stretch's start, m.
        """
        s = self.stretches[i]
        s0 = 0.0
        if s.parent is not None:
            j = self.junctions[s.parent]
            s0 = j.mouths[self._exit_index(j, i)]
        s1 = s.length
        if i in self.junctions:
            j = self.junctions[i]
            s1 = s.length - j.mouths[self._exit_index(j, i)]
        return s0, s1

    def rectangle(self, i: int) -> np.ndarray:
        """Return stretch ``i``'s rectangle of floor, between its mouths.

        Parameters
        ----------
        i : int
            Index of a stretch.

        Returns
        -------
        ndarray of shape (4, 2)
            Its corners, counter-clockwise, m.
        """
        s = self.stretches[i]
        s0, s1 = self.extent(i)
        u, n = _unit(s.heading), _left(s.heading)
        p0, h = np.asarray(s.start), self.half_width
        return np.array(
            [p0 + s0 * u - h * n, p0 + s1 * u - h * n, p0 + s1 * u + h * n, p0 + s0 * u + h * n]
        )

    def pieces(self) -> list[tuple[str, np.ndarray]]:
        """Return every convex piece of floor.

        Returns
        -------
        list of (str, ndarray)
            ``("stretch:i", rectangle)`` and ``("hub:i", polygon)``.
        """
        out = [(f"stretch:{i}", self.rectangle(i)) for i in range(len(self.stretches))]
        out += [(f"hub:{i}", j.polygon(self.half_width)) for i, j in self.junctions.items()]
        return out

    def regions(self) -> list[Region]:
        """Return each stretch's manifold: its rectangle and its sector of each hub it meets.

        Returns
        -------
        list of Region
            The regions, named after the stretches.
        """
        out = []
        for i, s in enumerate(self.stretches):
            out.append(Region(s.name, self.rectangle(i)))
            for owner, j in self.junctions.items():
                if owner == i or s.parent == owner:
                    out.append(Region(s.name, j.sector(self._exit_index(j, i), self.half_width)))
        return out

    def walls(self) -> list[Wall]:
        """Return both sides of every stretch, from corner to corner, and the closed ends.

        Returns
        -------
        list of Wall
            The walls (of length > 0).
        """
        out = []
        h = self.half_width
        for i, s in enumerate(self.stretches):
            u, n = _unit(s.heading), _left(s.heading)
            p0 = np.asarray(s.start)
            ends = {}
            for side, sign in (("left", 1.0), ("right", -1.0)):
                # start of this side: the parent's junction corner on this side, or the start
                if s.parent is None:
                    a, a_shift = p0 + sign * h * n, 1.0
                else:
                    j = self.junctions[s.parent]
                    k = self._exit_index(j, i)
                    c = k if side == "left" else (k - 1) % len(j.exits)
                    a, a_shift = j.corners[c], _corner_shift(j.gaps[c])
                if i in self.junctions:
                    j = self.junctions[i]
                    k = self._exit_index(j, i)
                    # seen from the stretch, its left side is the arriving exit's right side
                    c = (k - 1) % len(j.exits) if side == "left" else k
                    b, b_shift = j.corners[c], _corner_shift(j.gaps[c])
                else:
                    b, b_shift = p0 + s.length * u + sign * h * n, 1.0
                ends[side] = (a, b)
                if side == "left":  # free space on the wall's left: run it backwards
                    a, b, a_shift, b_shift = b, a, b_shift, a_shift
                out.append(Wall(tuple(a), tuple(b), i, "side", a_shift, b_shift))
            if s.parent is None:  # the closed end behind the start
                out.append(Wall(tuple(ends["left"][0]), tuple(ends["right"][0]), i, "end"))
            if i not in self.junctions:
                out.append(Wall(tuple(ends["right"][1]), tuple(ends["left"][1]), i, "end"))
        return [w for w in out if w.length > 1e-6]

    def bounds(self, margin: float = 0.0) -> tuple[float, float, float, float]:
        """Return the bounding box of the floor plan.

        Parameters
        ----------
        margin : float, default 0.0
            Added on every side, m.

        Returns
        -------
        tuple of float
            ``(xmin, xmax, ymin, ymax)``, m.
        """
        pts = np.concatenate([p for _, p in self.pieces()])
        lo, hi = pts.min(axis=0) - margin, pts.max(axis=0) + margin
        return float(lo[0]), float(hi[0]), float(lo[1]), float(hi[1])

    # -- routes -----------------------------------------------------------------------------
    def routes(self) -> dict[str, Route]:
        """Return one teleop route per leaf.

        Each runs from the main stretch's start through each junction's centre to the leaf's
        closed end, named after the leaf's manifold.

        Returns
        -------
        dict of str to Route
            The routes, by the leaves' manifold names.
        """
        out = {}
        for leaf in self.leaves():
            path = self.path(leaf)
            root = self.stretches[path[0]]
            points = [np.asarray(root.start) + self.route_start * _unit(root.heading)]
            for prev, nxt in pairwise(path):
                c = self.stretches[prev].end
                heading_in = self.stretches[prev].heading
                heading_out = self.stretches[nxt].heading
                points += [
                    c - self.turn_in * _unit(heading_in),
                    c + self.turn_in * _unit(heading_out),
                ]
            s = self.stretches[leaf]
            points.append(s.end - self.route_end_margin * _unit(s.heading))
            out[s.name] = Route(
                s.name, np.array(points), s.branch or "main", {"junctions": len(path) - 1}
            )
        return out
