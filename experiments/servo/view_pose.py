"""Dev check of ``ViewPose``: metric poses against stored views, scored
by the truth (for diagnosis only; the controller never sees it).

For ``--views`` random stored views of a world (``default_rng(5)``), ``--renders`` images are
rendered at random poses in each view's true frame (2.5 m behind to 0.5 m ahead, 0.8 m to
either side, 0.15 rad turned either way) and posed against the view with its verified depth
model (``ViewPose.pose``; a view the map check refuses is posed with all keypoints, and
reported apart). Prints how many views the map check verifies, the share of renders posed,
the median errors, the share within 0.2 / 0.4 m across, and the time per pose::

    python -m experiments.servo.view_pose hallway [--views 40] [--renders 4]
"""

from __future__ import annotations

import argparse
import time

import numpy as np

import sim  # noqa: F401  (the GL backend before mujoco)
from common.geometry import se2_compose
from servo.camera_only.view_pose import ViewPose
from servo.maps.build import load_or_build
from servo.task.env import ServoEnv


def main() -> None:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("world", choices=["hallway", "lawn"])
    p.add_argument("--views", type=int, default=40)
    p.add_argument("--renders", type=int, default=4)
    p.add_argument("--data", default="out/dataset")
    p.add_argument("--maps", default="out/servo-maps")
    a = p.parse_args()
    m = load_or_build(a.world, dataset=a.data, cache=a.maps)
    env = ServoEnv(a.world, m)
    vp = ViewPose(m)
    rng = np.random.default_rng(5)
    views = [int(v) for v in rng.choice(len(m), a.views, replace=False)]
    start = time.perf_counter()
    verified = {v: vp.depth_model(v) is not None for v in views}
    check_ms = (time.perf_counter() - start) / len(views) * 1e3
    print(
        f"{a.world}: {sum(verified.values())} of {len(views)} views verified "
        f"({check_ms:.0f} ms per view)"
    )
    rows, times = [], []
    for v in views:
        for _ in range(a.renders):
            true = np.array(
                [rng.uniform(-2.5, 0.5), rng.uniform(-0.8, 0.8), rng.uniform(-0.15, 0.15)]
            )
            env.base.sim.reset(se2_compose(m.true_poses[v], true), np.random.default_rng(0))
            image = env.base.sim.render()
            t = time.perf_counter()
            rel = vp.pose(image, v) if verified[v] else vp.relative(image, v)
            times.append(time.perf_counter() - t)
            err = np.full(3, np.nan) if rel is None else np.abs(rel.pose - true)
            rows.append((verified[v], *err))
    env.close()
    R = np.array(rows, float)
    for name, sel in (("verified", R[:, 0] > 0), ("refused", R[:, 0] == 0)):
        E = R[sel, 1:]
        posed = np.isfinite(E[:, 0])
        if not posed.any():
            continue
        E = E[posed]
        print(
            f"{name:9s} renders {sel.sum():3d}, posed {posed.mean():.2f}; median error along "
            f"{np.median(E[:, 0]):.3f} m, across {np.median(E[:, 1]):.3f} m, heading "
            f"{np.median(E[:, 2]):.4f} rad; across within 0.2 m {np.mean(E[:, 1] < 0.2):.2f},"
            f" within 0.4 m {np.mean(E[:, 1] < 0.4):.2f}"
        )
    print(f"one pose: median {np.median(times) * 1e3:.1f} ms")


if __name__ == "__main__":
    main()
