"""``ManifoldServoConfig``: bad settings are refused when made; the old name ``ServoConfig``
still gives it for one release, with a ``DeprecationWarning`` naming the new name."""

import importlib

import pytest

from servo.laser_image import ManifoldServoConfig


@pytest.mark.parametrize(
    ("field", "value", "match"),
    [
        ("speed", 2.0, "speed"),
        ("turn_rate", 0.0, "turn_rate"),
        ("lost_fit", 1.5, "lost_fit"),
        ("lost_steps", 0, "lost_steps"),
        ("max_drift", -1.0, "max_drift"),
        ("arrive_radius", 0.4, "arrive_radius"),
        ("keep_off", float("nan"), "keep_off"),
    ],
)
def test_servo_config_refuses_bad_values(field, value, match):
    with pytest.raises(ValueError, match=match):
        ManifoldServoConfig(**{field: value})


@pytest.mark.parametrize("old", ["servo.laser_image", "servo.laser_image.controller"])
def test_the_old_name_gives_the_config_and_names_the_new_one(old):
    module = importlib.import_module(old)
    new = r"import ManifoldServoConfig from servo\.laser_image "
    with pytest.warns(DeprecationWarning, match=new):
        value = module.ServoConfig
    assert value is ManifoldServoConfig
    with pytest.warns(DeprecationWarning, match="ManifoldServoConfig"):
        exec(f"from {old} import ServoConfig", {})


def test_the_face_still_gives_its_other_names_and_refuses_unknown_ones():
    face = importlib.import_module("servo.laser_image")
    assert face.ManifoldServoConfig is ManifoldServoConfig
    assert "ServoConfig" not in face.__all__
    with pytest.raises(AttributeError, match="no_such_name"):
        face.no_such_name  # noqa: B018
