"""Dev diagnosis of ``SignalServo``: what its episodes did, beside the truth.

Runs ``dev`` episodes of the benchmark protocol exactly as ``topomap servo-eval`` does (the
same specs, starts, env and 600 steps) and prints per episode the end, the phase it ended
in, when the arrival began and where the robot really was against where it believed it was,
both in the target view's frame (along its sight, across it, heading). The truth is read
for diagnosis only; the controller never sees it. Any ``SignalServoConfig`` field can be
set (``--config '{"speed": 1.0}'``), which is how the controller's variants are compared on dev::

    python -m experiments.servo.signal_servo hallway anywhere 0:24 [--config JSON] [--trace FROM]

``--trace FROM``: also a line every 5 steps from step FROM (phase, arrival stage, truth,
belief, command, contact, bumps) and every relocalisation with the belief's error.

``--oracle-fix view|pose|top5`` gives the controller a perfect global fix at every observing
turn, the start's and each relocalisation's: ``view`` the stored view
nearest the true position and the heading that faces it (the start pose then as the
controller finds it), ``pose`` also the true pose in that view's frame; ``top5``
a perfect choice among the candidates the turn offers: of the controller's own five best
places by contrast score (views 4 m or more apart,
`servo.camera_only.turn_global_fix.contrast_scores`), the one nearest the truth. What a better
global fix is worth, against the same episodes without it. Diagnosis only: the controller never sees
the truth.

``--by-start-distance FILE...`` reads ``topomap servo-eval --out`` files (checked by
``servo.task.paired_comparison.load_results``) and counts successes by how far each start lies from
the nearest stored view (truth, for the analysis only).

``--sight VIEWS`` instead renders the world at offsets along stored views' sight (-1.6 to
1.6 m) and prints F^j(k) toward each view there (eq. 13): how sharp the peak the arrival
looks for is, and where it repeats (measured: ~0 at 0.4 m, secondary peaks near 1 m in the
hallway). Dev splits only: the test split is run once per frozen controller with
``servo-eval``.
"""

from __future__ import annotations

import argparse
import json

import numpy as np

import sim  # noqa: F401  (the GL backend before mujoco)
from common.geometry import se2_compose, se2_relative, wrap_angle
from servo.camera_only.controller import SignalServo, SignalServoConfig
from servo.maps.build import load_or_build
from servo.task.env import ServoEnv
from servo.task.protocol import Protocol, episode_specs, reset_options


def _fmt(p) -> str:
    return "(" + ",".join(f"{v:+.2f}" for v in p) + ")"


def _view_distances(m, pose) -> np.ndarray:
    """Each stored view's true distance (m) from ``pose``'s position (truth: diagnosis)."""
    return np.linalg.norm(m.true_poses[:, :2] - np.asarray(pose, np.float64)[:2], axis=1)


class _OracleFix:
    """Patches ``SignalServo``'s global fix with the truth (``--oracle-fix``)."""

    def __init__(self, pol: SignalServo, m, mode: str):
        import servo.camera_only.controller as module  # here: ``sim`` chose the GL backend first

        self.m, self.mode, self.truth, self.odo = m, mode, None, None
        module.contrast_fix = self.fix
        if mode == "pose" and pol.poses is not None:
            pol.poses.start = self.start

    def see(self, info, obs) -> None:
        self.truth = np.asarray(info["pose"], np.float64)
        self.odo = np.asarray(obs["odometry"], np.float64)

    def fix(self, *args, **kwargs) -> tuple[int, float]:
        if self.mode == "top5":
            return self._best_of(*args, far=kwargs["far"])
        v = int(np.argmin(_view_distances(self.m, self.truth)))
        return v, float(self.m.true_poses[v, 2] - self.truth[2] + self.odo[2])

    def _best_of(self, d, yaw, h, *, far, places=5, apart=4.0):
        from servo.camera_only.turn_global_fix import contrast_scores

        score, facing = contrast_scores(d, yaw, h, far=far)
        chosen = []
        for v in np.argsort(score, kind="stable"):
            far_from = _view_distances(self.m, self.m.true_poses[v])[chosen]
            if np.all(far_from >= apart):
                chosen.append(int(v))
            if len(chosen) == places:
                break
        v = chosen[int(np.argmin(_view_distances(self.m, self.truth)[chosen]))]
        return v, float(facing[v])

    def start(self, view, distances, path, odometry):
        return se2_compose(path.frames[0], se2_relative(self.m.true_poses[view], self.truth))


def episodes(env, m, world, tier, lo, hi, config, trace_from, oracle=None):
    pol = SignalServo(m, config=config, world=world)
    oracle = _OracleFix(pol, m, oracle) if oracle else None
    print(f"parallax {pol.parallax:.3f} rad/m, reverses {pol.reverses}", flush=True)
    specs = episode_specs(Protocol(world, tier, "dev"), m.true_labels, hi)[lo:hi]
    wins = 0
    for spec in specs:
        obs, info = env.reset(seed=spec.seed, options=reset_options(env, spec, tier))
        target = np.asarray(info["target_pose"])
        pol.reset(info["target_view"], info)
        steps, arrive_at, entry, relocs, last = 0, None, None, 0, None
        off = _view_distances(m, info["pose"]).min()
        while True:
            if oracle is not None:
                oracle.see(info, obs)
            action = pol.act(obs, info)
            obs, _, terminated, truncated, info = env.step(action)
            steps += 1
            true = se2_relative(target, np.asarray(info["pose"]))
            b = pol.belief_
            believed = se2_relative(b.path.frames[-1], b.pose) if b is not None else None
            stage = pol._arrival.stage if pol.phase_ in ("arrive", "done") else ""
            if stage and arrive_at is None:
                arrive_at, entry = steps, (true, believed)
            if pol.relocalised_ > relocs and last is not None:
                relocs = pol.relocalised_
                err = last[0] - last[1]
                err[2] = wrap_angle(err[2])
                print(
                    f"   relocalise #{relocs} at {steps}: bumps {pol.bumps_}, distance "
                    f"{info['distance']:.2f}, belief error {_fmt(err)}"
                )
            if believed is not None:
                last = (true, believed)
            if trace_from is not None and steps >= trace_from and steps % 5 == 0 and b:
                print(
                    f"  {steps:3d} {pol.phase_:7s} {stage:6s} d {info['distance']:.2f} true "
                    f"{_fmt(true)} belief {_fmt(believed)} cmd {_fmt(action)} contact "
                    f"{int(info['collision'])} bumps {pol.bumps_}"
                )
            if terminated or truncated:
                break
        wins += info["reason"] == "success"
        head = (
            f"ep {spec.index:2d} {spec.start_manifold} -> {spec.target_manifold} (start "
            f"{off:.1f} m from the nearest view): "
            f"{info['reason']}, {steps} steps, final {info['distance']:.2f} m, ended in "
            f"{pol.phase_}/{stage or '-'}, relocalised {pol.relocalised_}"
        )
        if entry is not None:
            head += (
                f"; arrival from step {arrive_at}: true {_fmt(entry[0])} belief {_fmt(entry[1])}"
            )
        print(head, flush=True)
    print(f"successes {wins}/{len(specs)}")


BINS = ((0.0, 1.0), (1.0, 2.0), (2.0, 3.0), (3.0, 5.0), (5.0, np.inf))


def by_start_distance(files, data, maps) -> None:
    from servo.task.paired_comparison import load_results

    for path in files:
        for r in load_results(path, "FILE"):
            m = load_or_build(r["world"], dataset=data, cache=maps)
            near, won = [], []
            for e in r["episodes_detail"]:
                start = np.asarray(e.get("start_pose"), np.float64)
                if start.shape != (3,) or not np.all(np.isfinite(start)):
                    raise ValueError(f"FILE: episode {e['episode']} has no finite start_pose")
                near.append(_view_distances(m, start).min())
                won.append(e["success"])
            near, won = np.array(near), np.array(won)
            cells = []
            for lo, hi in BINS:
                sel = (near >= lo) & (near < hi)
                cells.append(f"{lo:g}-{hi:g} m: {int(won[sel].sum())}/{int(sel.sum())}")
            print(f"{path} ({r['world']}, {r['tier']}): " + ", ".join(cells))


def sight(env, m, views):
    from servo.localise import ImageLocaliser

    loc = ImageLocaliser(m)
    offsets = np.round(np.arange(-1.6, 1.61, 0.2), 2)
    print("offset along the sight (m): " + " ".join(f"{o:+.1f}" for o in offsets))
    for v in views:
        p = m.true_poses[v]
        u = np.array([np.cos(p[2]), np.sin(p[2]), 0.0])
        f = []
        for o in offsets:
            env.base.sim.reset(p + o * u, np.random.default_rng(0))
            f.append(loc.signal(loc.features(env.base.sim.render()), int(v)))
        print(f"view {v:4d}: F " + " ".join(f"{x:.2f}" for x in f))


def main(argv=None):
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("world")
    p.add_argument("tier", nargs="?", default="anywhere")
    p.add_argument("episodes", nargs="?", default="0:24", help="LO:HI of the dev split")
    p.add_argument("--config", default="{}", help="SignalServoConfig fields as JSON")
    p.add_argument("--trace", type=int, default=None, metavar="FROM")
    p.add_argument(
        "--oracle-fix",
        choices=["view", "pose", "top5"],
        default=None,
        help="a perfect global fix (diagnosis)",
    )
    p.add_argument("--by-start-distance", nargs="+", default=None, metavar="FILE")
    p.add_argument("--sight", default=None, metavar="VIEWS", help="comma-separated views")
    p.add_argument("--data", default="out/dataset")
    p.add_argument("--maps", default="out/servo-maps")
    a = p.parse_args(argv)
    if a.by_start_distance:
        return by_start_distance(a.by_start_distance, a.data, a.maps)
    m = load_or_build(a.world, dataset=a.data, cache=a.maps)
    env = ServoEnv(a.world, m, max_steps=600, odometry_noise=True)
    try:
        if a.sight:
            sight(env, m, [int(v) for v in a.sight.split(",")])
        else:
            lo, hi = (int(x) for x in a.episodes.split(":"))
            config = SignalServoConfig(**json.loads(a.config))
            episodes(env, m, a.world, a.tier, lo, hi, config, a.trace, a.oracle_fix)
    finally:
        env.close()


if __name__ == "__main__":
    main()
