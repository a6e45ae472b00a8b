"""Dev measurement behind the image-distance arrival (``arrive_descent``, measured in decision
record 059 and removed, 076): how the image's distance to a stored view, and F^j(k) toward
it, vary around the view.

For each view the world is rendered on a square grid of points about the view's true pose
(``--radius`` m either way along and across its sight, ``--step`` m apart) facing the view's
heading give or take a normal error (``--heading-noise`` rad: what the robot's belief
carries), and two things are read toward the view: the shift-minimised image distance
(`servo.localise.ImageLocaliser.align`) and F (eq. 13,
`signal`). Printed per view:

* F at the view itself and the median F beyond 1 m (how much F says once the heading is off);
* the catchment of the distance: the share of the grid points, by ring of distance from the
  view, from which greedy descent over the 8 neighbours ends within one grid step of it;
* the side probe: at the view's along position, the share of the points across from which a
  probe ``--probe`` m to either side reads less distance on the side toward the view.

Truth is read to place the camera, for diagnosis only (the controller never sees it)::

    python -m experiments.servo.arrival_descent lawn --views 10,40,70,100,130,160,190,210
"""

from __future__ import annotations

import argparse

import numpy as np

import sim  # noqa: F401  (the GL backend before mujoco)
from servo.localise import ImageLocaliser
from servo.maps.build import load_or_build
from servo.task.env import ServoEnv

RINGS = ((0.0, 1.0), (1.0, 2.0), (2.0, 3.0), (3.0, np.inf))


def grid_readings(env, loc, m, view, offsets, noise, rng):
    """(distance, F) toward ``view`` rendered at every (along, across) grid offset."""
    p = m.true_poses[view]
    c, s = np.cos(p[2]), np.sin(p[2])
    n = len(offsets)
    D, F = np.empty((n, n)), np.empty((n, n))
    for i, a in enumerate(offsets):
        for j, b in enumerate(offsets):
            pose = p + np.array([a * c - b * s, a * s + b * c, rng.normal(0.0, noise)])
            env.base.sim.reset(pose, np.random.default_rng(0))
            x = loc.features(env.base.sim.render())
            D[i, j] = loc.align(x, [view])[0][0]
            F[i, j] = loc.signal(x, view)
    return D, F


def catchment(D: np.ndarray) -> np.ndarray:
    """Whether greedy descent over the 8 neighbours from each grid point ends within one
    step of the centre."""
    n, o = D.shape[0], D.shape[0] // 2
    caught = np.zeros_like(D, bool)
    for i in range(n):
        for j in range(n):
            ci, cj = i, j
            while True:
                nb = [
                    (ci + di, cj + dj)
                    for di in (-1, 0, 1)
                    for dj in (-1, 0, 1)
                    if 0 <= ci + di < n and 0 <= cj + dj < n
                ]
                bi, bj = min(nb, key=lambda q: D[q])
                if D[bi, bj] >= D[ci, cj]:
                    break
                ci, cj = bi, bj
            caught[i, j] = max(abs(ci - o), abs(cj - o)) <= 1
    return caught


def side_probe(D: np.ndarray, offsets: np.ndarray, probe: float) -> float:
    """Share of the points across the view (at its along position) where the reading
    ``probe`` m toward the view is below the one ``probe`` m away from it."""
    o, k = len(offsets) // 2, round(probe / (offsets[1] - offsets[0]))
    right = []
    for j, b in enumerate(offsets):
        if b == 0 or not (0 <= j - k and j + k < len(offsets)):
            continue
        toward, away = (j - k, j + k) if b > 0 else (j + k, j - k)
        right.append(D[o, toward] < D[o, away])
    return float(np.mean(right)) if right else float("nan")


def main(argv=None):
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("world")
    p.add_argument("--views", required=True, help="comma-separated stored views")
    p.add_argument("--radius", type=float, default=3.0)
    p.add_argument("--step", type=float, default=0.5)
    p.add_argument("--probe", type=float, default=1.0)
    p.add_argument("--heading-noise", type=float, default=0.1)
    p.add_argument("--seed", type=int, default=0)
    p.add_argument("--data", default="out/dataset")
    p.add_argument("--maps", default="out/servo-maps")
    a = p.parse_args(argv)
    m = load_or_build(a.world, dataset=a.data, cache=a.maps)
    env = ServoEnv(a.world, m, max_steps=600)
    loc = ImageLocaliser(m)
    offsets = np.round(np.arange(-a.radius, a.radius + 1e-9, a.step), 6)
    ring = np.hypot(*np.meshgrid(offsets, offsets, indexing="ij"))
    rng = np.random.default_rng(a.seed)
    try:
        for v in (int(s) for s in a.views.split(",")):
            D, F = grid_readings(
                env, loc, m, m.check_view(v, "views"), offsets, a.heading_noise, rng
            )
            caught = catchment(D)
            rings = " ".join(
                f"{np.mean(caught[(ring > lo) & (ring <= hi)]):.2f}"
                for lo, hi in RINGS
                if ((ring > lo) & (ring <= hi)).any()
            )
            o = len(offsets) // 2
            print(
                f"view {v} ({m.sequence_names[m.sequence[v]]}): F at the view "
                f"{F[o, o]:.2f}, median F beyond 1 m {np.median(F[ring > 1]):.2f}; "
                f"distance at the view {D[o, o]:.3f}, median {np.median(D):.3f}; "
                f"descent reaches the view from (by ring 0-1, 1-2, 2-3, 3+ m) {rings}; "
                f"side probe right {side_probe(D, offsets, a.probe):.2f}",
                flush=True,
            )
    finally:
        env.close()


if __name__ == "__main__":
    main()
