"""Closed-loop servoing between manifolds (the paper's Section II-G, run in simulation).

``servo.ServoEnv`` is the task (registered as ``topomap/HallwayServo-v0`` and
``topomap/LawnServo-v0`` on import), ``servo.ManifoldServo`` the laser+image controller,
``servo.SignalServo`` the camera-only one that servoes by F^j(k), ``servo.protocol`` the
benchmark protocol, ``servo.baselines`` its comparisons, ``servo.compare`` two evaluations
paired episode by episode and ``servo.evaluate`` the closed-loop evaluation (the module: its
function is ``servo.evaluate.evaluate``). Heavy modules load lazily.
"""

from importlib import import_module

import sim  # noqa: F401  (headless GL backend before mujoco; base envs registered)
from servo.registration import register_envs

_EXPORTS = {
    "MapError": "servo.map_store",
    "MapSettings": "servo.map_store",
    "ServoMap": "servo.map_store",
    "build_map": "servo.map_store",
    "load_or_build": "servo.map_store",
    "ServoEnv": "servo.env",
    "ManifoldServo": "servo.controller",
    "SignalServo": "servo.signal_servo",
    "SignalServoConfig": "servo.signal_servo",
    "Protocol": "servo.protocol",
    "run_protocol": "servo.protocol",
}
# submodules served lazily as themselves. ``evaluate`` once also named the function
# ``servo.evaluate.evaluate`` here, so ``servo.evaluate`` was the function until the module
# was first imported and the module after: one name, one thing
_MODULES = ("evaluate",)

__all__ = sorted((*_EXPORTS, *_MODULES))

register_envs()


def __getattr__(name):
    if name in _MODULES:
        return import_module(f"servo.{name}")
    try:
        module = _EXPORTS[name]
    except KeyError:
        raise AttributeError(f"module 'servo' has no attribute {name!r}") from None
    return getattr(import_module(module), name)
