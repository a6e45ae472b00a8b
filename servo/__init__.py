"""Closed-loop servoing between manifolds (the paper's Section II-G, run in simulation).

The subpackages follow the data flow: `servo.maps` builds and stores the map a robot
servoes on (its recordings, clustered by the manifold method and linked by ICP);
`servo.laser_image` is [`ManifoldServo`][servo.laser_image.controller.ManifoldServo], the laser +
image controller; `servo.camera_only` is [`SignalServo`][servo.camera_only.controller.SignalServo],
the camera-only controller that servoes by F^j(k); `servo.task` is the task
([`ServoEnv`][servo.task.env.ServoEnv], registered as ``topomap/HallwayServo-v0`` and
``topomap/LawnServo-v0`` on import), the benchmark protocol, the closed-loop evaluation
(``servo.evaluate``, the module), the baseline policies and the paired comparison. The modules
beside them are the tools both controllers use: image localisation, the route graph, steering, the
waypoint tracker and the geodesic field. Heavy modules load lazily.
"""

import sim  # noqa: F401  (headless GL backend before mujoco; base envs registered)
from common.lazy import lazy_exports
from servo.task import register_envs

__getattr__, __dir__, __all__ = lazy_exports(
    __name__,
    {
        "SignalServo": "servo.camera_only",
        "SignalServoConfig": "servo.camera_only",
        "ManifoldServo": "servo.laser_image",
        "ManifoldServoConfig": "servo.laser_image",
        "MapError": "servo.maps",
        "MapSettings": "servo.maps",
        "ServoMap": "servo.maps",
        "build_map": "servo.maps",
        "load_or_build": "servo.maps",
        "Protocol": "servo.task",
        "ServoEnv": "servo.task",
        "run_protocol": "servo.task",
    },
    # the closed-loop evaluation, served as the module (its function is
    # ``servo.evaluate.evaluate``): one name, one thing
    modules={"evaluate": "servo.task.evaluation"},
)

register_envs()
