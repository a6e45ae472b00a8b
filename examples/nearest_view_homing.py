r"""An outside baseline on the servo benchmark: homing along a route of stored views.

What a user of a topological map would write first ("teach and repeat"): find the stored view
the current image looks most like, plan the shortest route to the target over the map's view
graph (``servo_map.edges``, weighted by the scan-matched odometry between views), and follow
it by image alignment alone: turn so that the next views' images line up with the camera's
(the column shift that best matches them), drive on, and move along the route as the best
matching view of the route's next few moves ahead. No metric localisation; the laser only
with ``clearance`` (turn away from a wall ahead).

Run by the benchmark as an outside policy::

    topomap servo-eval --world hallway --split test --episodes 20 \\
        --policy examples.nearest_view_homing:make_policy --out out/homing
"""

from __future__ import annotations

import cv2
import numpy as np
from scipy.sparse import coo_matrix
from scipy.sparse.csgraph import dijkstra

SIZE = (64, 48)  # (width, height) the images are compared at
FOV = np.deg2rad(57.8)  # rad: the camera's horizontal field of view (45 deg vertical, 4:3)
MAX_SHIFT = 16  # columns (at SIZE) the alignment searches either way
WINDOW = 6  # route views ahead searched for the best match
LOOKAHEAD = 2  # route views ahead of the matched one steered toward
AHEAD = np.deg2rad(30.0)  # rad: the beams either side of straight ahead ``clearance`` watches


def _features(images: np.ndarray) -> np.ndarray:
    """Grey images at ``SIZE``, each zero-mean and unit-norm (a change of light cancels)."""
    out = []
    for im in np.asarray(images, np.uint8).reshape(-1, *np.shape(images)[-3:]):
        g = cv2.resize(cv2.cvtColor(im, cv2.COLOR_RGB2GRAY), SIZE, interpolation=cv2.INTER_AREA)
        g = g.astype(np.float32) - g.mean()
        out.append(g / max(float(np.linalg.norm(g)), 1e-6))
    return np.array(out)


def _shift(a: np.ndarray, b: np.ndarray) -> tuple[int, float]:
    """Return the column shift of best overlap between two images, and its correlation.

    The shift s maximises the overlap of ``a[:, s:]`` and ``b[:, :-s]`` (or the other way
    for s < 0).
    """
    best, score = 0, -np.inf
    w = a.shape[1]
    for s in range(-MAX_SHIFT, MAX_SHIFT + 1):
        x, y = (a[:, s:], b[:, : w - s]) if s >= 0 else (a[:, : w + s], b[:, -s:])
        c = float((x * y).sum() / max(np.linalg.norm(x) * np.linalg.norm(y), 1e-9))
        if c > score:
            best, score = s, c
    return best, score


class RouteHoming:
    """Follow the route of stored views from the best-matching one to the target.

    Parameters
    ----------
    servo_map : ServoMap
        The map as sensed.
    speed : float
        Forward speed, m/s.
    gain : float
        Turn rate per radian of misalignment, 1/s.
    clearance : float
        With a laser return nearer than this within 30 deg of straight ahead, m, stop and turn
        toward the more open side (0: off, images only).
    """

    def __init__(self, servo_map, speed: float = 0.6, gain: float = 2.0, clearance: float = 0.0):
        if not (0 < speed <= 1.5 and gain > 0 and clearance >= 0):
            raise ValueError(
                f"speed must be in (0, 1.5], gain > 0 and clearance >= 0, got "
                f"{speed}, {gain}, {clearance}"
            )
        self.speed, self.gain, self.clearance = float(speed), float(gain), float(clearance)
        self.angles = np.asarray(servo_map.angles, float)
        self.features = _features(servo_map.images)
        e = np.asarray(servo_map.edges)
        length = np.linalg.norm(np.asarray(servo_map.edge_transforms)[:, :2], axis=1) + 1e-3
        n = len(self.features)
        self.graph = coo_matrix((length, (e[:, 0], e[:, 1])), shape=(n, n)).tocsr()

    def reset(self, target) -> None:
        """Start a new episode toward stored view ``target.view``."""
        self.target = int(target.view)
        self.route: list[int] | None = None
        self.k = 0

    def _plan(self, x: np.ndarray) -> None:
        start = int(np.argmax(self.features.reshape(len(self.features), -1) @ x.ravel()))
        _, pred = dijkstra(self.graph, directed=False, indices=start, return_predecessors=True)
        route, v = [self.target], self.target
        while v != start and pred[v] >= 0:
            v = int(pred[v])
            route.append(v)
        self.route = route[::-1] if v == start else [self.target]

    def act(self, observation: dict) -> np.ndarray:
        """(v, omega) toward the route's view ``LOOKAHEAD`` past the best-matching one."""
        x = _features(observation["image"])[0]
        if self.route is None:
            self._plan(x)
        ahead = self.route[self.k : self.k + WINDOW]
        scores = self.features[ahead].reshape(len(ahead), -1) @ x.ravel()
        self.k += int(np.argmax(scores))
        goal = self.route[min(self.k + LOOKAHEAD, len(self.route) - 1)]
        s, _ = _shift(x, self.features[goal])
        # a positive shift: the view's scene lies to the right in the camera image, turn right
        omega = float(np.clip(-self.gain * s * FOV / SIZE[0], -1.5, 1.5))
        last = self.k >= len(self.route) - 1
        v = (0.25 if last else self.speed) * max(0.0, 1.0 - abs(omega) / 1.5)
        if self.clearance > 0:
            scan = np.asarray(observation["scan"], float)
            ahead = np.abs(self.angles) < AHEAD
            if scan[ahead].min() < self.clearance:  # a wall ahead: turn to the open side
                left = scan[ahead & (self.angles > 0)].min()
                right = scan[ahead & (self.angles < 0)].min()
                return np.array([0.0, 1.0 if left > right else -1.0], np.float32)
        return np.array([v, omega], np.float32)


def make_policy(
    servo_map,
    rng: np.random.Generator,
    speed: float = 0.6,
    gain: float = 2.0,
    clearance: float = 0.0,
):
    """Make the policy: the factory of ``--policy examples.nearest_view_homing:make_policy``."""
    return RouteHoming(servo_map, speed=float(speed), gain=float(gain), clearance=float(clearance))
