"""A simulated unicycle for the arrival tests (``PeakArrival``)."""

import numpy as np

from common.geometry import se2_compose
from servo.camera_only.route_belief import RouteBelief
from servo.route import RoutePath
from sim.simulator import CONTROL_DT


def drive_arrival(arrival, true_view_xy, steps):
    """Run ``arrival`` on a unicycle whose belief puts the view at (4, 0) facing +x while it
    really is at ``true_view_xy`` (the belief is off). F is a sharp bump at the true view
    (~0 at 0.4 m, as measured on rendered views). Returns the closest approach to the true
    view and the final distance to it."""
    path = RoutePath(np.array([[0.0, 0.0, 0.0], [2.0, 0.0, 0.0], [4.0, 0.0, 0.0]]))
    belief = RouteBelief(path, [3.0, 0.0, 0.0])
    pose = np.array([3.0, 0.0, 0.0])  # the truth, in the same frame
    closest = np.inf
    for _ in range(steps):
        r2 = float(np.sum((pose[:2] - true_view_xy) ** 2))
        f = float(np.exp(-r2 / (2 * 0.15**2)))
        v, w = arrival.step(belief, path.frames[-1], lambda f=f: f)
        step = np.array([v * CONTROL_DT, 0.0, w * CONTROL_DT])
        pose = se2_compose(pose, step)
        belief.predict(step)
        closest = min(closest, float(np.hypot(*(pose[:2] - true_view_xy))))
    return closest, float(np.hypot(*(pose[:2] - true_view_xy)))
