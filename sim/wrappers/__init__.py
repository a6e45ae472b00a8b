"""Wrappers of the envs for reinforcement learning: observations as one ``Box``.

The wrappers (``observations``) give the camera image alone, resized and grayscale if asked;
the laser scan alone; a small float32 vector of the scan and the odometry.
"""

from common.lazy import lazy_exports

__getattr__, __dir__, __all__ = lazy_exports(
    __name__,
    {
        "ImageObservation": "sim.wrappers.observations",
        "ScanObservation": "sim.wrappers.observations",
        "ScanOdometryObservation": "sim.wrappers.observations",
    },
)
