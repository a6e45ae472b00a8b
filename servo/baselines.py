"""What ``ManifoldServo`` is compared with: a random policy, the paper's literal greedy
F-probing, and an oracle that knows the true pose (the upper bound).

Every policy has ``reset(target, info)`` and ``act(observation, info) -> (v, omega)``; only the
oracle reads ``info`` (the simulator's truth).
"""

from __future__ import annotations

import numpy as np

from mapping.topology import se2_relative
from scenes import World
from servo.geodesic import GeodesicField
from servo.map_store import ServoMap
from servo.steering import Arrival, pursue
from sim.simulator import OMEGA_LIMIT, V_LIMITS


class RandomPolicy:
    """Uniform random commands, each held for ``hold`` steps (a lower bound)."""

    def __init__(self, rng: np.random.Generator, hold: int = 5):
        if not isinstance(rng, np.random.Generator):
            raise TypeError(f"rng must be a numpy.random.Generator, got {type(rng).__name__}")
        self.rng, self.hold = rng, int(hold)
        self._left, self._action = 0, np.zeros(2)

    def reset(self, target: int, info: dict | None = None) -> None:
        self._left = 0

    def act(self, observation, info: dict | None = None) -> np.ndarray:
        if self._left == 0:
            self._action = self.rng.uniform((V_LIMITS[0], -OMEGA_LIMIT), (V_LIMITS[1], OMEGA_LIMIT))
            self._left = self.hold
        self._left -= 1
        return self._action.astype(np.float32)


# Small motions a probe can undo exactly by the opposite command: (v, omega) for one step.
PROBES = np.array([(0.5, 0.0), (0.4, 0.8), (0.4, -0.8), (0.0, 1.0), (0.0, -1.0), (-0.5, 0.0)])


class GreedyFProbing:
    """The paper's greedy servo, literally: probe candidate motions, keep the one that raises
    F^j(k) toward the target most (eq. 13), repeat.

    Each probe is executed for one step, F is read from the next image, and the probe is
    undone by the opposite command; after all probes the best is executed ``commit`` times.
    """

    def __init__(self, servo_map: ServoMap, commit: int = 3):
        self.map, self.commit = servo_map, int(commit)

    def reset(self, target: int, info: dict | None = None) -> None:
        self.target = self.map.check_view(target, "target")
        self._cluster = int(self.map.clusters[self.target])
        self._plan: list[tuple[str, int]] = []
        self._scores = np.full(len(PROBES), -np.inf)
        self._pending: int | None = None

    def _signal(self, image) -> float:
        x = self.map.image_features.transform(np.asarray(image)[None]).astype(np.float32)
        return float(self.map.clustering.signal(x, self._cluster, self.target)[0])

    def act(self, observation, info: dict | None = None) -> np.ndarray:
        if self._pending is not None:  # the image after a probe: score it
            self._scores[self._pending] = self._signal(observation["image"])
            self._pending = None
        if not self._plan:
            if np.isfinite(self._scores).all():
                best = int(np.argmax(self._scores))
                self._plan = [("go", best)] * self.commit
                self._scores[:] = -np.inf
            else:
                self._plan = [x for k in range(len(PROBES)) for x in (("probe", k), ("undo", k))]
        kind, k = self._plan.pop(0)
        if kind == "probe":
            self._pending = k
            return PROBES[k].astype(np.float32)
        return (-PROBES[k] if kind == "undo" else PROBES[k]).astype(np.float32)


class OraclePolicy:
    """Follows the shortest free-space route to the target using the *true* pose.

    Same steering as the controller (pure pursuit, then the arrival law), so the gap between
    the two is what localisation from images and scans costs.
    """

    def __init__(self, world: World, speed: float = 1.0, lookahead: float = 1.0):
        self.world, self.speed, self.lookahead = world, float(speed), float(lookahead)

    def reset(self, target: int, info: dict | None = None) -> None:
        if info is None or "target_pose" not in info:
            raise ValueError("OraclePolicy.reset needs the env's info (target_pose)")
        self.target_pose = np.asarray(info["target_pose"], np.float64)
        self.field = GeodesicField(self.world, self.target_pose)
        self._arrival = Arrival()

    def act(self, observation, info: dict | None = None) -> np.ndarray:
        if info is None or "pose" not in info:
            raise ValueError("OraclePolicy.act needs the env's info (pose)")
        pose = np.asarray(info["pose"], np.float64)
        goal = se2_relative(pose, self.target_pose)
        if self.field.distance(pose[:2]) < self.lookahead:
            return self._arrival(goal).astype(np.float32)
        n = int(np.ceil(self.lookahead / self.field.grid.resolution)) + 1
        ahead = self.field.path(pose[:2], max_points=n)[-1]
        point = se2_relative(pose, np.r_[ahead, 0.0])
        return pursue(point[:2], self.speed).astype(np.float32)
