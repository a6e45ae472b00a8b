"""The camera-only controller and what only it uses.

[`SignalServo`][servo.camera_only.controller.SignalServo] servoes by maximising F^j(k) toward
the target view (Grudic & Mulligan, Section II-G). Its modules:

* ``controller`` and ``config`` -- the controller and its settings;
* ``route_belief`` -- the robot's pose on its route, from odometry and image fixes;
  ``route_image_fix`` -- those fixes, from the route view the image matches best;
* ``view_pose`` -- the camera's metric pose against a stored view (keypoints at the view's
  depths, PnP); ``metric_pose_fixes`` -- such poses taken along the route;
* ``turn_global_fix`` -- the global position fix of an observing turn, checked across the turn;
* ``rear_view_heading`` -- the heading fix from views behind a robot driving a route turned
  round;
* ``peak_arrival`` -- the arrival at the target view, at the peak of F toward it.
"""

from common.lazy import lazy_exports

__getattr__, __dir__, __all__ = lazy_exports(
    __name__,
    {
        "SignalServo": "servo.camera_only.controller",
        "SignalServoConfig": "servo.camera_only.config",
    },
)
