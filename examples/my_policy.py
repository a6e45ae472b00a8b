r"""A policy of your own on the servo benchmark: the template.

A policy is an object with ``reset(target)`` and ``act(observation) -> (v, omega)``
(``servo.task.Policy``); a factory ``factory(servo_map, rng, **params)`` makes it
(``servo.task.PolicyFactory``). The runner gives it the target as a stored view
(``target.view``, ``target.image``), the env's observations (``image``, ``scan``,
``scan_valid``, ``odometry`` relative to the episode's start, ``target_image``, ...), the map as
sensed recordings (images, scans, scan-matched odometry, clusters learned without labels; no
true pose, no label) and a seeded ``numpy.random.Generator``. Nothing else: no true pose.

This one drives straight and turns away from the nearest obstacle ahead: replace ``act``.
Evaluate it on the benchmark's test split, beside the built-in policies::

    topomap servo-eval --world hallway --split test --episodes 20 \\
        --policy examples.my_policy:make_policy --policy-arg speed=0.6 --out out/mine

``topomap servo-eval`` imports ``examples.my_policy`` as ``python -m`` would (its code runs);
an episode whose policy raises, returns NaN or an action outside ``[-0.5, 1.5] x [-1.5, 1.5]``,
or takes over 10 s for a step fails with that reason, and the run goes on. Or run this file,
``python -m examples.my_policy --episodes 4``, from the repository root.
"""

from __future__ import annotations

import argparse

import numpy as np

CLEARANCE = 0.8  # m: an obstacle nearer than this ahead makes the policy turn
AHEAD = np.deg2rad(30.0)  # rad: the beams either side of straight ahead that count


class WallAvoider:
    """Drive at ``speed``; turn away from an obstacle within ``CLEARANCE`` ahead."""

    def __init__(self, angles: np.ndarray, rng: np.random.Generator, speed: float = 0.5):
        if not 0 < speed <= 1.5:
            raise ValueError(f"speed must be in (0, 1.5] m/s, got {speed!r}")
        self.angles, self.rng, self.speed = np.asarray(angles), rng, float(speed)

    def reset(self, target) -> None:
        """Start a new episode toward stored view ``target.view`` (its image: ``target.image``)."""
        self.target = target.view

    def act(self, observation: dict) -> np.ndarray:
        """(v, omega): straight on, or a turn away from the nearer side's obstacle."""
        scan = np.asarray(observation["scan"], float)
        ahead = np.abs(self.angles) < AHEAD
        if scan[ahead].min() > CLEARANCE:
            return np.array([self.speed, 0.0], np.float32)
        left = scan[ahead & (self.angles > 0)].min()
        right = scan[ahead & (self.angles < 0)].min()
        return np.array([0.0, -1.0 if left < right else 1.0], np.float32)


def make_policy(servo_map, rng: np.random.Generator, speed: float = 0.5) -> WallAvoider:
    """Make the policy.

    The factory ``topomap servo-eval --policy examples.my_policy:make_policy`` calls.
    """
    return WallAvoider(servo_map.angles, rng, speed=float(speed))


def main(argv: list[str] | None = None) -> None:
    """Run the policy on the dev split's episodes and print its results."""
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--world", default="hallway", help="hallway or lawn")
    p.add_argument("--episodes", type=int, default=4, help="episodes of the dev split")
    p.add_argument("--map", default=None, help="a saved servo map (default: the data home's)")
    args = p.parse_args(argv)

    import sim  # noqa: F401  (the headless GL backend before mujoco)
    from servo.maps import load_or_build
    from servo.task import Protocol, run_protocol

    servo_map = args.map or load_or_build(args.world)
    result = run_protocol(
        Protocol(args.world, split="dev"),
        servo_map,
        args.episodes,
        "examples.my_policy:make_policy",
        workers=1,
    )
    low, high = result["success_ci95"]
    print(
        f"success {result['success_rate']:.2f} [{low:.2f}, {high:.2f}], reasons {result['reasons']}"
    )


if __name__ == "__main__":
    main()
