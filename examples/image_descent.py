r"""An outside baseline on the servo benchmark: descent on the image difference to the target.

The simplest homing a user might try without any map structure: the difference between the
camera image and the target's image should fall as the robot nears the target, so descend it
by run and tumble (as a bacterium climbs a gradient): drive straight while the difference
falls; when it has not fallen for ``patience`` steps, turn on the spot by a random angle (from
the seeded generator the runner gives) and run again. It reads the camera and the target image
only; the map it is given goes unused.

Run by the benchmark as an outside policy::

    topomap servo-eval --world hallway --split test --episodes 20 \\
        --policy examples.image_descent:make_policy --out out/descent
"""

from __future__ import annotations

import cv2
import numpy as np

SIZE = (64, 48)  # (width, height) the images are compared at
TURN_RATE = 1.0  # rad/s while tumbling
STEP_S = 0.1  # s per env step (sim.simulator's control period)


def _grey(image: np.ndarray) -> np.ndarray:
    g = cv2.resize(
        cv2.cvtColor(np.asarray(image, np.uint8), cv2.COLOR_RGB2GRAY),
        SIZE,
        interpolation=cv2.INTER_AREA,
    ).astype(np.float32)
    g -= g.mean()
    return g / max(float(np.linalg.norm(g)), 1e-6)


class RunAndTumble:
    """Run while the image difference to the target falls, else tumble by a random turn.

    Parameters
    ----------
    rng : numpy.random.Generator
        Draws the tumbles' angles.
    speed : float
        Running speed, m/s.
    patience : int
        Steps without a new lowest difference before a tumble.
    """

    def __init__(self, rng: np.random.Generator, speed: float = 0.5, patience: int = 8):
        if not (0 < speed <= 1.5 and int(patience) >= 1):
            raise ValueError(f"speed must be in (0, 1.5], patience >= 1; got {speed}, {patience}")
        self.rng, self.speed, self.patience = rng, float(speed), int(patience)

    def reset(self, target) -> None:
        """Start a new episode toward the view whose image is ``target.image``."""
        self.goal = _grey(target.image)
        self.best, self.since, self.turn = np.inf, 0, 0

    def act(self, observation: dict) -> np.ndarray:
        """(v, omega): the run, or the tumble's turn."""
        if self.turn:
            self.turn -= 1
            return np.array([0.0, TURN_RATE], np.float32)
        d = float(np.linalg.norm(_grey(observation["image"]) - self.goal))
        if d < self.best:
            self.best, self.since = d, 0
        else:
            self.since += 1
        if self.since >= self.patience:
            angle = self.rng.uniform(0.3, 2 * np.pi - 0.3)
            self.turn = max(1, round(angle / (TURN_RATE * STEP_S)))
            self.since, self.best = 0, d
            return np.array([0.0, TURN_RATE], np.float32)
        return np.array([self.speed, 0.0], np.float32)


def make_policy(servo_map, rng: np.random.Generator, speed: float = 0.5, patience: int = 8):
    """Make the policy: the factory of ``--policy examples.image_descent:make_policy``."""
    return RunAndTumble(rng, speed=float(speed), patience=int(patience))
