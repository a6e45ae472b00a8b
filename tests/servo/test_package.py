"""The package's lazy names: each is one thing, whatever was imported before it."""

import subprocess
import sys
import types

import servo

# a fresh interpreter: in this one other tests may already have imported the modules
FRESH = """
import servo
first = servo.evaluate
from servo import evaluate
import servo.task.evaluation as module
assert first is evaluate is module, (first, evaluate, module)
assert callable(module.evaluate)
"""


def test_servo_evaluate_is_always_the_module():
    done = subprocess.run([sys.executable, "-c", FRESH], capture_output=True, text=True)
    assert done.returncode == 0, done.stderr


def test_every_exported_name_resolves():
    for name in servo.__all__:
        assert getattr(servo, name) is not None
    assert isinstance(servo.evaluate, types.ModuleType)
    assert servo.SignalServo.__name__ == "SignalServo"
