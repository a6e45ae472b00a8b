"""The laser + image controller, its settings, and what only it uses.

The controller is [`ManifoldServo`][servo.laser_image.controller.ManifoldServo] (``controller``),
its settings [`ManifoldServoConfig`][servo.laser_image.config.ManifoldServoConfig] (``config``);
only it uses localisation by the laser against the map's metric map
(``laser_localise``, ``metric_map``) and the scan match of the current view against a stored one
(``view_match``).
"""

from common.deprecation import moved_names
from common.lazy import lazy_exports

_face_getattr, __dir__, __all__ = lazy_exports(
    __name__,
    {
        "ManifoldServo": "servo.laser_image.controller",
        "ManifoldServoConfig": "servo.laser_image.config",
    },
)
# the settings' old name, kept for one release with a DeprecationWarning
__getattr__ = moved_names(
    __name__, {"ServoConfig": "servo.laser_image:ManifoldServoConfig"}, _face_getattr
)[0]
