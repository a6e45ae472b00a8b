"""Synthetic 2-D laser scans of a polygon world, for tests, docs and benchmarks.

A small office like the one of Blanco et al., Fig. 5: a straight corridor with rooms along one
side, each room reached through a door. Walls are line segments; scans are ray-cast with numpy
(one ray-segment intersection per beam and wall). The ground-truth region of each pose (room
``k`` or the corridor) lets tests and docs score the observation groups.

Nothing here is used by the mapping methods themselves; the real scans come from the simulator.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from common.geometry import se2_compose, se2_relative, wrap_angle

__all__ = [
    "OfficeWorld",
    "office_path",
    "office_world",
    "raycast",
    "simulate_odometry",
]

# Sensor: a SICK-like planar laser, 181 beams over 180 degrees.
N_BEAMS = 181
FIELD_OF_VIEW = np.pi
MAX_RANGE = 8.0

ROOM_WIDTH = 6.0  # along the corridor (m)
ROOM_DEPTH = 5.0  # away from the corridor (m)
CORRIDOR_WIDTH = 2.0
DOOR_WIDTH = 1.0
WALL_THICKNESS = 0.15
WALL_EPS = 1e-12  # a beam parallel to a wall never hits it


@dataclass(frozen=True)
class OfficeWorld:
    """Walls of a corridor (``0 < y < corridor_width``) with ``n_rooms`` rooms above it.

    Parameters
    ----------
    segments : ndarray of shape (S, 4)
        Wall segments ``(x0, y0, x1, y1)``.
    n_rooms : int
        Number of rooms.
    room_width, room_depth, corridor_width, door_width : float
        Sizes in metres, as in ``office_world``.

    Attributes
    ----------
    segments : ndarray of shape (S, 4)
        Wall segments ``(x0, y0, x1, y1)``.
    n_rooms, room_width, room_depth, corridor_width, door_width : see ``office_world``.
    """

    segments: np.ndarray
    n_rooms: int
    room_width: float
    room_depth: float
    corridor_width: float
    door_width: float

    def region_labels(self, poses: np.ndarray) -> np.ndarray:
        """Return the ground-truth region of each pose.

        Room ``k`` (0-based, left to right) or the corridor (label ``n_rooms``).

        Parameters
        ----------
        poses : ndarray of shape (N, 3)
            ``(x, y, yaw)`` poses in the world frame.

        Returns
        -------
        ndarray of int, shape (N,)
            Region of each pose.
        """
        poses = np.asarray(poses, dtype=float)
        room = np.clip((poses[:, 0] // self.room_width).astype(int), 0, self.n_rooms - 1)
        return np.where(poses[:, 1] > self.corridor_width, room, self.n_rooms)

    def door_x(self, k: int) -> float:
        """Return the x of the centre of room ``k``'s door.

        Parameters
        ----------
        k : int
            Room, 0-based from the left.

        Returns
        -------
        float
            The door's x in metres.
        """
        return (k + 0.5) * self.room_width


def office_world(
    n_rooms: int = 4,
    room_width: float = ROOM_WIDTH,
    room_depth: float = ROOM_DEPTH,
    corridor_width: float = CORRIDOR_WIDTH,
    door_width: float = DOOR_WIDTH,
    wall_thickness: float = WALL_THICKNESS,
) -> OfficeWorld:
    """Build the office: outer walls, room dividers and the corridor wall with one door per room.

    Parameters
    ----------
    n_rooms : int, default 4
        Rooms along the corridor.
    room_width : float, default 6.0
        Width of a room along the corridor, in metres.
    room_depth : float, default 5.0
        Depth of a room away from the corridor, in metres.
    corridor_width : float, default 2.0
        Width of the corridor, in metres.
    door_width : float, default 1.0
        Width of each door, in metres.
    wall_thickness : float, default 0.15
        Thickness of the walls in metres; 0 keeps them as centre lines.

    Returns
    -------
    OfficeWorld
        The walls and the sizes.
    """
    length = n_rooms * room_width
    top = corridor_width + room_depth
    segs = [
        (0.0, 0.0, length, 0.0),  # corridor floor-side wall
        (0.0, 0.0, 0.0, top),  # west end
        (length, 0.0, length, top),  # east end
        (0.0, top, length, top),  # back wall of the rooms
    ]
    for k in range(1, n_rooms):
        segs.append((k * room_width, corridor_width, k * room_width, top))
    for k in range(n_rooms):
        x0, x1 = k * room_width, (k + 1) * room_width
        door = (k + 0.5) * room_width
        segs.append((x0, corridor_width, door - door_width / 2, corridor_width))
        segs.append((door + door_width / 2, corridor_width, x1, corridor_width))
    return OfficeWorld(
        _thicken(np.asarray(segs, dtype=float), wall_thickness),
        n_rooms,
        room_width,
        room_depth,
        corridor_width,
        door_width,
    )


def _thicken(segments: np.ndarray, thickness: float) -> np.ndarray:
    """Replace each centre-line segment by the four sides of a wall ``thickness`` thick.

    Real walls have two faces; with zero-thickness walls two scans taken on opposite sides of
    a wall would see the same points and overlap, which no real laser does.
    """
    if thickness <= 0:
        return segments
    p0, p1 = segments[:, :2], segments[:, 2:]
    d = p1 - p0
    d /= np.linalg.norm(d, axis=1, keepdims=True)
    h = thickness / 2
    n = np.column_stack([-d[:, 1], d[:, 0]]) * h
    a, b = p0 - d * h, p1 + d * h  # extend so that corners close
    c = [a + n, b + n, b - n, a - n]
    sides = [np.hstack([c[k], c[(k + 1) % 4]]) for k in range(4)]
    return np.concatenate(sides, axis=0)


def office_path(world: OfficeWorld, step: float = 0.5) -> np.ndarray:
    """Poses along a route that goes down the corridor and tours every room.

    The route enters each room through its door, drives a rectangle inside it, leaves and
    continues east. Poses are sampled every ``step`` metres of path, heading along the motion.

    Parameters
    ----------
    world : OfficeWorld
        The office to tour.
    step : float, default 0.5
        Metres of path between poses.

    Returns
    -------
    ndarray of shape (N, 3)
        ``(x, y, yaw)`` poses in the world frame.
    """
    y_corr = world.corridor_width / 2
    y_in = world.corridor_width + 1.0
    y_far = world.corridor_width + world.room_depth - 1.2
    way = [(0.8, y_corr)]
    for k in range(world.n_rooms):
        xd = world.door_x(k)
        x_lo = k * world.room_width + 1.2
        x_hi = (k + 1) * world.room_width - 1.2
        way += [(xd, y_corr), (xd, y_in), (x_hi, y_in), (x_hi, y_far), (x_lo, y_far)]
        way += [(x_lo, y_in), (xd, y_in), (xd, y_corr)]
    way.append((world.n_rooms * world.room_width - 0.8, y_corr))
    way = np.asarray(way, dtype=float)
    seg = np.diff(way, axis=0)
    seg_len = np.hypot(seg[:, 0], seg[:, 1])
    keep = seg_len > 0
    way = np.concatenate([way[:1], way[1:][keep]])
    seg, seg_len = seg[keep], seg_len[keep]
    cum = np.concatenate([[0.0], np.cumsum(seg_len)])
    s = np.arange(0.0, cum[-1], step)
    idx = np.clip(np.searchsorted(cum, s, side="right") - 1, 0, len(seg) - 1)
    frac = (s - cum[idx]) / seg_len[idx]
    xy = way[idx] + frac[:, None] * seg[idx]
    yaw = np.arctan2(seg[idx, 1], seg[idx, 0])
    return np.column_stack([xy, yaw])


def raycast(
    segments: np.ndarray,
    poses: np.ndarray,
    n_beams: int = N_BEAMS,
    fov: float = FIELD_OF_VIEW,
    max_range: float = MAX_RANGE,
    range_noise: float = 0.0,
    rng: np.random.Generator | None = None,
) -> list[np.ndarray]:
    """Simulate a planar laser at each pose.

    Each beam ``o + t u`` hits segment ``a + s (b - a)`` where ``t = ((a - o) x e) / (u x e)``
    and ``s = ((a - o) x u) / (u x e)``, ``e = b - a``; the nearest hit with ``t > 0`` and
    ``0 <= s <= 1`` is the range. Beams without a hit within ``max_range`` are dropped, so a
    scan may have no points.

    Parameters
    ----------
    segments : ndarray of shape (S, 4)
        Wall segments ``(x0, y0, x1, y1)``.
    poses : ndarray of shape (N, 3)
        Sensor poses ``(x, y, yaw)`` in the world frame.
    n_beams : int, default 181
        Beams per scan, evenly spread over ``fov``.
    fov : float, default pi
        Field of view in radians, centred on the heading.
    max_range : float, default 8.0
        Range limit in metres.
    range_noise : float, default 0.0
        Standard deviation of Gaussian noise added to each range, in metres.
    rng : numpy.random.Generator, optional
        Source of the noise; required when ``range_noise > 0``.

    Returns
    -------
    list of ndarray of shape (M_i, 2)
        Points in the sensor frame (x forward, y left).
    """
    if range_noise > 0 and rng is None:
        raise ValueError("rng is required when range_noise > 0")
    angles = np.linspace(-fov / 2, fov / 2, n_beams)
    a, e = segments[:, :2], segments[:, 2:] - segments[:, :2]
    poses = np.asarray(poses, dtype=float)
    scans = []
    # poses in chunks of ~4M beam-wall tests: vectorised, and memory stays bounded
    chunk = max(1, 4_000_000 // max(1, n_beams * len(segments)))
    for start in range(0, len(poses), chunk):
        x, y, yaw = poses[start : start + chunk].T
        th = angles[None, :] + yaw[:, None]
        u = np.stack([np.cos(th), np.sin(th)], axis=-1)  # (P, K, 2)
        ao = a[None, :, :] - np.stack([x, y], axis=-1)[:, None, :]  # (P, S, 2)
        denom = u[:, :, None, 0] * e[None, None, :, 1] - u[:, :, None, 1] * e[None, None, :, 0]
        ok = np.abs(denom) > WALL_EPS
        safe = np.where(ok, denom, 1.0)
        t = (
            ao[:, None, :, 0] * e[None, None, :, 1] - ao[:, None, :, 1] * e[None, None, :, 0]
        ) / safe
        s = (ao[:, None, :, 0] * u[:, :, None, 1] - ao[:, None, :, 1] * u[:, :, None, 0]) / safe
        hit = ok & (t > 1e-9) & (s >= 0.0) & (s <= 1.0)
        ranges = np.where(hit, t, np.inf).min(axis=2)  # (P, K)
        for rng_k in ranges:
            valid = rng_k <= max_range
            r = rng_k[valid]
            if range_noise > 0:
                r = r + rng.normal(0.0, range_noise, r.shape)
            scans.append(np.column_stack([r * np.cos(angles[valid]), r * np.sin(angles[valid])]))
    return scans


def simulate_odometry(
    poses: np.ndarray,
    rng: np.random.Generator,
    sigma_translation: float = 0.05,
    sigma_rotation: float = 0.02,
) -> np.ndarray:
    """Return dead-reckoned poses from noisy increments of the true ``poses``.

    Each true increment ``d_i = poses[i-1] ⊖ poses[i]`` gets independent Gaussian noise
    (``sigma_translation`` metres per metre travelled on x and y, ``sigma_rotation`` radians
    per step on the heading), and the noisy increments are chained from ``poses[0]``, so the
    error drifts like real odometry.

    Parameters
    ----------
    poses : ndarray of shape (N, 3)
        True poses ``(x, y, yaw)``.
    rng : numpy.random.Generator
        Source of the noise.
    sigma_translation : float, default 0.05
        Translation noise in metres per metre travelled.
    sigma_rotation : float, default 0.02
        Heading noise in radians per step.

    Returns
    -------
    ndarray of shape (N, 3)
        The odometry poses, starting at ``poses[0]``.
    """
    poses = np.asarray(poses, dtype=float)
    inc = se2_relative(poses[:-1], poses[1:])
    dist = np.hypot(inc[:, 0], inc[:, 1])[:, None]
    noise = np.column_stack(
        [
            rng.normal(0.0, 1.0, (len(inc), 2)) * sigma_translation * dist,
            rng.normal(0.0, sigma_rotation, len(inc)),
        ]
    )
    noisy = inc + noise
    noisy[:, 2] = wrap_angle(noisy[:, 2])
    out = np.empty_like(poses)
    out[0] = poses[0]
    for i, d in enumerate(noisy, start=1):
        out[i] = se2_compose(out[i - 1], d)
    return out
