"""Dev diagnosis of ``SignalServo`` (issue 12 item 2): what its episodes did, beside the truth.

Runs ``dev`` episodes of the benchmark protocol exactly as ``topomap servo-eval`` does (the
same specs, starts, env and 600 steps) and prints per episode the end, the phase it ended
in, when the arrival began and where the robot really was against where it believed it was,
both in the target view's frame (along its sight, across it, heading). The truth is read
for diagnosis only; the controller never sees it. Any ``SignalServoConfig`` field can be
set (``--config '{"speed": 1.0}'``), which is how round 6's variants were compared::

    python bench/signal_servo_dev.py hallway anywhere 0:24 [--config JSON] [--trace FROM]

``--trace FROM``: also a line every 5 steps from step FROM (phase, arrival stage, truth,
belief, command, contact, bumps) and every relocalisation with the belief's error.

``--sight VIEWS`` instead renders the world at offsets along stored views' sight (-1.6 to
1.6 m) and prints F^j(k) toward each view there (eq. 13): how sharp the peak the arrival
looks for is, and where it repeats (round 6: ~0 at 0.4 m, secondary peaks near 1 m in the
hallway). Dev splits only: the test split is run once per round with ``servo-eval``.
"""

from __future__ import annotations

import argparse
import json

import numpy as np

import sim  # noqa: F401  (the GL backend before mujoco)
from common.geometry import se2_relative, wrap_angle
from servo.env import ServoEnv
from servo.map_store import load_or_build
from servo.protocol import Protocol, episode_specs, reset_options
from servo.signal_servo import SignalServo, SignalServoConfig


def _fmt(p) -> str:
    return "(" + ",".join(f"{v:+.2f}" for v in p) + ")"


def episodes(env, m, world, tier, lo, hi, config, trace_from):
    pol = SignalServo(m, config=config, world=world)
    print(f"parallax {pol.parallax:.3f} rad/m, reverses {pol.reverses}", flush=True)
    specs = episode_specs(Protocol(world, tier, "dev"), m.true_labels, hi)[lo:hi]
    wins = 0
    for spec in specs:
        obs, info = env.reset(seed=spec.seed, options=reset_options(env, spec, tier))
        target = np.asarray(info["target_pose"])
        pol.reset(info["target_view"], info)
        steps, arrive_at, entry, relocs, last = 0, None, None, 0, None
        while True:
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
                print(f"   relocalise #{relocs} at {steps}: bumps {pol.bumps_}, distance "
                      f"{info['distance']:.2f}, belief error {_fmt(err)}")  # fmt: skip
            if believed is not None:
                last = (true, believed)
            if trace_from is not None and steps >= trace_from and steps % 5 == 0 and b:
                print(f"  {steps:3d} {pol.phase_:7s} {stage:6s} d {info['distance']:.2f} true "
                      f"{_fmt(true)} belief {_fmt(believed)} cmd {_fmt(action)} contact "
                      f"{int(info['collision'])} bumps {pol.bumps_}")  # fmt: skip
            if terminated or truncated:
                break
        wins += info["reason"] == "success"
        head = (f"ep {spec.index:2d} {spec.start_manifold} -> {spec.target_manifold}: "
                f"{info['reason']}, {steps} steps, final {info['distance']:.2f} m, ended in "
                f"{pol.phase_}/{stage or '-'}, relocalised {pol.relocalised_}")  # fmt: skip
        if entry is not None:
            head += (f"; arrival from step {arrive_at}: true {_fmt(entry[0])} belief "
                     f"{_fmt(entry[1])}")  # fmt: skip
        print(head, flush=True)
    print(f"successes {wins}/{len(specs)}")


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
    p.add_argument("--sight", default=None, metavar="VIEWS", help="comma-separated views")
    p.add_argument("--data", default="out/dataset")
    p.add_argument("--maps", default="out/servo-maps")
    a = p.parse_args(argv)
    m = load_or_build(a.world, dataset=a.data, cache=a.maps)
    env = ServoEnv(a.world, m, max_steps=600, odometry_noise=True)
    try:
        if a.sight:
            sight(env, m, [int(v) for v in a.sight.split(",")])
        else:
            lo, hi = (int(x) for x in a.episodes.split(":"))
            config = SignalServoConfig(**json.loads(a.config))
            episodes(env, m, a.world, a.tier, lo, hi, config, a.trace)
    finally:
        env.close()


if __name__ == "__main__":
    main()
