"""Every env keyword is checked: an unknown one names what is accepted (on all four ids, by
``gym.make`` and by the class), and an ill-typed value names its parameter, the servo env's
before any map is looked for."""

import inspect

import gymnasium as gym
import pytest

import servo  # noqa: F401  (registers the servo ids)
import sim  # noqa: F401  (registers the navigation ids)
from common.validation import check_keywords
from servo.task.env import ServoEnv
from sim.env import NavigationEnv

IDS = {
    "topomap/Hallway-v0": NavigationEnv,
    "topomap/Lawn-v0": NavigationEnv,
    "topomap/HallwayServo-v0": ServoEnv,
    "topomap/LawnServo-v0": ServoEnv,
}

NAVIGATION_BAD = {
    "world": 5,
    "render_mode": "human",
    "camera": 5,
    "laser": "wide",
    "odometry": [1.0],
    "sensors": "scan",
    "randomize": 1,
    "collision_penalty": "1",
    "appearance": "easy",
    "no_return": None,
    "registered_world": 5,
}

SERVO_BAD = {
    "world": 5,
    "servo_map": 3,
    "max_steps": 0,
    "cross_manifold": "yes",
    "randomize": 1,
    "odometry_noise": None,
    "render_mode": "human",
    "signal_weight": float("nan"),
    "success_reward": "1",
    "collision_penalty": [0.1],
    "no_return": "zero",
    "registered_world": 5,
}


def _accepted(cls) -> list[str]:
    return list(inspect.signature(cls.__init__).parameters)[1:]


@pytest.mark.parametrize("env_id", sorted(IDS))
def test_an_unknown_keyword_names_every_accepted_one(env_id):
    with pytest.raises(TypeError) as err:
        gym.make(env_id, no_such_option=1)
    message = str(err.value)
    assert "'no_such_option'" in message
    assert all(name in message for name in _accepted(IDS[env_id]))


def test_the_servo_env_refuses_a_camera_naming_what_it_takes(tmp_path, monkeypatch):
    monkeypatch.setenv("TOPOMAP_HOME", str(tmp_path / "absent"))  # no data is looked for
    with pytest.raises(TypeError, match=r"unknown keyword 'camera'.*servo_map, max_steps"):
        gym.make("topomap/HallwayServo-v0", camera={"width": 64})


def test_a_misspelt_keyword_gets_the_closest_one():
    with pytest.raises(TypeError, match=r"'camra' \(did you mean 'camera'\?\)"):
        NavigationEnv(camra={"width": 64})
    with pytest.raises(TypeError, match="did you mean 'max_steps'"):
        ServoEnv("hallway", max_step=5)


def test_too_many_positional_arguments_are_refused():
    with pytest.raises(TypeError, match="at most 11 positional arguments"):
        NavigationEnv(*([None] * 12))


@pytest.mark.parametrize("name", sorted(NAVIGATION_BAD))
def test_an_ill_typed_navigation_keyword_names_itself(name):
    with pytest.raises((TypeError, ValueError), match=name):
        NavigationEnv(**{name: NAVIGATION_BAD[name]})


@pytest.mark.parametrize("name", sorted(SERVO_BAD))
def test_an_ill_typed_servo_keyword_names_itself_before_any_data(name, tmp_path, monkeypatch):
    monkeypatch.setenv("TOPOMAP_HOME", str(tmp_path / "absent"))  # a map load would fail
    with pytest.raises((TypeError, ValueError), match=name):
        ServoEnv(**{name: SERVO_BAD[name]})


def test_every_keyword_of_the_envs_has_a_bad_value_here():
    assert set(NAVIGATION_BAD) == set(_accepted(NavigationEnv))
    assert set(SERVO_BAD) == set(_accepted(ServoEnv))


def test_a_function_with_var_keywords_is_not_checked():
    def anything(self, **kwargs):
        return kwargs

    check_keywords(anything, (), {"x": 1}, "anything")
