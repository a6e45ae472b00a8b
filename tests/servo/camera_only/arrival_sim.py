"""A simulated unicycle for the arrival tests (``PeakArrival``, ``DescentArrival``)."""

import numpy as np

from common.geometry import se2_compose
from servo.camera_only.route_belief import RouteBelief
from servo.route import RoutePath
from sim.simulator import CONTROL_DT


def drive_arrival(arrival, true_view_xy, steps, wall=None):
    """Run ``arrival`` on a unicycle whose belief puts the view at (4, 0) facing +x while it
    really is at ``true_view_xy`` (the belief is off). F is a sharp bump at the true view
    (~0 at 0.4 m, as measured on rendered views); the image distance a wide funnel into it
    (as rendered around lawn views). ``wall``: y above which the robot cannot go (a bump:
    the step is undone and reported to ``arrival.blocked``). Returns the closest approach
    to the true view and the final distance to it."""
    path = RoutePath(np.array([[0.0, 0.0, 0.0], [2.0, 0.0, 0.0], [4.0, 0.0, 0.0]]))
    belief = RouteBelief(path, [3.0, 0.0, 0.0])
    pose = np.array([3.0, 0.0, 0.0])  # the truth, in the same frame
    closest = np.inf
    for _ in range(steps):
        r2 = float(np.sum((pose[:2] - true_view_xy) ** 2))
        f, d = float(np.exp(-r2 / (2 * 0.15**2))), 0.01 + 0.1 * np.sqrt(r2)
        v, w = arrival.step(belief, path.frames[-1], lambda f=f: f, lambda d=d: d)
        step = np.array([v * CONTROL_DT, 0.0, w * CONTROL_DT])
        moved = se2_compose(pose, step)
        if wall is not None and moved[1] > wall:
            arrival.blocked()
            continue
        pose = moved
        belief.predict(step)
        closest = min(closest, float(np.hypot(*(pose[:2] - true_view_xy))))
    return closest, float(np.hypot(*(pose[:2] - true_view_xy)))
