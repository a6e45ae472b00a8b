"""The laser + image controller, [`ManifoldServo`][servo.laser_image.controller.ManifoldServo]
(``controller``), and what only it uses: localisation by the laser against the map's metric map
(``laser_localise``, ``metric_map``) and the scan match of the current view against a stored one
(``view_match``).
"""

from common.lazy import lazy_exports

__getattr__, __dir__, __all__ = lazy_exports(
    __name__,
    {
        "ManifoldServo": "servo.laser_image.controller",
        "ServoConfig": "servo.laser_image.controller",
    },
)
