import warnings

import gymnasium as gym
import numpy as np
import pytest
from gymnasium.utils.env_checker import check_env

import sim  # noqa: F401  (registers the envs)
from sim.camera import CameraConfig

# check_env's advice we deliberately do not take: (v, omega) keep their physical units. The
# scan is bounded by the laser's range by default; no_return="inf" (REP 117) is unbounded.
EXPECTED_WARNINGS = ("symmetric and normalized space",)
SMALL = {"camera": CameraConfig(width=64, height=48)}


@pytest.mark.parametrize("env_id", ["topomap/Hallway-v0", "topomap/Lawn-v0"])
def test_check_env_passes_without_unexpected_warnings(env_id):
    env = gym.make(env_id, render_mode="rgb_array", **SMALL)
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        check_env(env.unwrapped)
    unexpected = [
        str(w.message) for w in caught if not any(e in str(w.message) for e in EXPECTED_WARNINGS)
    ]
    assert unexpected == []
    env.reset(seed=0)
    frame = env.render()
    assert frame.ndim == 3 and frame.dtype == np.uint8 and frame.std() > 10
    env.close()
    env.close()


def _rollout(seed: int):
    env = gym.make("topomap/Hallway-v0", randomize=True, **SMALL)
    obs, info = env.reset(seed=seed)
    images, scans, poses = [obs["image"]], [obs["scan"]], [info["pose"]]
    env.action_space.seed(seed)
    for _ in range(15):
        obs, _, _, _, info = env.step(env.action_space.sample())
        images.append(obs["image"])
        scans.append(obs["scan"])
        poses.append(info["pose"])
    env.close()
    return np.array(images), np.array(scans), np.array(poses)


def test_same_seed_same_observations_bit_for_bit():
    a, b, c = _rollout(5), _rollout(5), _rollout(6)
    for x, y in zip(a, b, strict=True):
        np.testing.assert_array_equal(x, y)
    assert not np.array_equal(a[2], c[2])


def test_actions_are_validated_and_clipped():
    env = gym.make("topomap/Lawn-v0", sensors=("scan",))
    env.reset(seed=0, options={"pose": (5.0, 0.0, 0.0)})
    with pytest.raises(ValueError, match=r"action must have shape \(2,\)"):
        env.step(np.zeros(3))
    with pytest.raises(ValueError, match="action must be finite"):
        env.step(np.array([np.nan, 0.0]))
    for _ in range(10):
        _, _, _, _, info = env.step(np.array([100.0, 0.0]))  # clipped to 1.5 m/s
    assert info["pose"][0] == pytest.approx(5.0 + 1.5, abs=0.1)
    assert info["manifold"] == "lawn"
    env.close()


def test_bad_arguments_name_the_choices():
    with pytest.raises(ValueError, match="world must be 'hallway' or 'lawn'"):
        gym.make("topomap/Hallway-v0", world="moon")
    with pytest.raises(ValueError, match="sensors must be a non-empty subset"):
        gym.make("topomap/Hallway-v0", sensors=("sonar",))
    with pytest.raises(ValueError, match="appearance must be one of"):
        gym.make("topomap/Hallway-v0", appearance="dark")
    env = gym.make("topomap/Hallway-v0", sensors=("scan",))
    with pytest.raises(ValueError, match="not in free space"):
        env.reset(seed=0, options={"pose": (5.0, 3.0, 0.0)})
    with pytest.raises(ValueError, match="manifold must be one of"):
        env.reset(seed=0, options={"manifold": "attic"})
    obs, info = env.reset(seed=0, options={"manifold": "hallway-right"})
    assert info["manifold"] == "hallway-right" and set(obs) == {"scan", "scan_valid"}
    env.close()


def test_async_vector_env_runs():
    envs = gym.vector.AsyncVectorEnv(
        [lambda: gym.make("topomap/Hallway-v0", **SMALL) for _ in range(2)], context="spawn"
    )
    try:
        obs, _ = envs.reset(seed=[1, 2])
        assert obs["image"].shape == (2, 48, 64, 3)
        for _ in range(3):
            obs, rewards, _, _, _ = envs.step(np.tile([0.5, 0.1], (2, 1)).astype(np.float32))
        assert obs["scan"].shape == (2, 361) and rewards.shape == (2,)
    finally:
        envs.close()


_FORK_AFTER_RENDER = """
import sim, gymnasium as gym
from sim.camera import CameraConfig
small = {"camera": CameraConfig(width=64, height=48)}
env = gym.make("topomap/Hallway-v0", **small)
env.reset(seed=0)  # the parent now holds a GL context
env.close()
envs = gym.make_vec("topomap/Hallway-v0", num_envs=2, vectorization_mode="async",
                    vector_kwargs={"context": "fork"}, **small)
try:
    obs, _ = envs.reset(seed=0)
    print("ok", obs["image"].shape)
finally:
    envs.close()
"""


@pytest.mark.parametrize("threads", [None, "2"])
def test_forked_vector_env_after_rendering_works_or_fails_at_once(threads):
    """The default (fork) context after the parent rendered: works with sim's default
    ``LP_NUM_THREADS=0``; with render threads on, fails at once saying to use spawn. A fresh
    interpreter, since Mesa reads the variable once; the timeout turns a hang into a failure."""
    import os
    import subprocess
    import sys

    env = {k: v for k, v in os.environ.items() if k != "LP_NUM_THREADS"}
    if threads:
        env["LP_NUM_THREADS"] = threads
    run = subprocess.run(
        [sys.executable, "-c", _FORK_AFTER_RENDER],
        env=env,
        capture_output=True,
        text=True,
        timeout=240,
    )
    if threads is None:
        assert run.returncode == 0 and "ok (2, 48, 64, 3)" in run.stdout, run.stderr[-2000:]
    else:
        assert run.returncode != 0
        assert "forked after its parent created an OpenGL context" in run.stderr
        assert "'context': 'spawn'" in run.stderr


@pytest.mark.parametrize("env_id", ["topomap/Hallway-v0", "topomap/Lawn-v0"])
def test_observations_are_finite_and_inside_their_bounds(env_id):
    """No return reads the laser's range, flagged by scan_valid; the raw ranges (+inf) agree
    with both where the option keeps them."""
    env = gym.make(env_id, **SMALL)
    raw = gym.make(env_id, no_return="inf", **SMALL)
    space, max_range = env.observation_space, env.unwrapped.laser_config.max_range
    assert space["scan"].high.max() == np.float32(max_range)
    assert isinstance(space["scan_valid"], gym.spaces.MultiBinary)
    assert set(raw.observation_space) == {"image", "scan"}
    misses = 0
    for seed in range(3):
        obs, _ = env.reset(seed=seed)
        obs_raw, _ = raw.reset(seed=seed)
        env.action_space.seed(seed)
        for step in range(10):
            assert space.contains(obs), (seed, step)
            assert all(np.isfinite(v).all() for v in obs.values())
            returned = np.isfinite(obs_raw["scan"])
            np.testing.assert_array_equal(obs["scan_valid"], returned)
            np.testing.assert_array_equal(obs["scan"][~returned], max_range)
            np.testing.assert_array_equal(
                obs["scan"][returned], np.minimum(obs_raw["scan"][returned], max_range)
            )
            np.testing.assert_array_equal(obs["image"], obs_raw["image"])
            misses += int((~returned).sum())
            action = env.action_space.sample()
            obs, *_ = env.step(action)
            obs_raw, *_ = raw.step(action)
    assert misses > 0  # the test saw beams with no return
    env.close()
    raw.close()


def test_normalised_flattened_observations_hold_no_nan():
    from gymnasium.wrappers import FlattenObservation, NormalizeObservation

    env = NormalizeObservation(FlattenObservation(gym.make("topomap/Lawn-v0", **SMALL)))
    obs, _ = env.reset(seed=0)
    env.action_space.seed(0)
    for _ in range(5):
        assert np.isfinite(obs).all()
        obs, reward, *_ = env.step(env.action_space.sample())
    assert np.isfinite(obs).all() and np.isfinite(reward)
    env.close()


@pytest.mark.parametrize(
    "kwargs, error, match",
    [
        ({"collision_penalty": float("nan")}, ValueError, "collision_penalty must be a finite"),
        ({"collision_penalty": "1"}, ValueError, "collision_penalty must be a finite"),
        ({"randomize": "yes"}, ValueError, "randomize must be True or False"),
        ({"sensors": "scan"}, ValueError, r"got the string 'scan'; write \('scan',\)"),
        ({"sensors": ("scan", "scan")}, ValueError, "without repeats"),
        ({"sensors": 3}, ValueError, "sensors must be a tuple of names"),
        ({"camera": {"width": 64, "hight": 48}}, ValueError, "did you mean 'height'"),
        ({"camera": (64, 48)}, TypeError, "camera must be a CameraConfig, a dict of its"),
        ({"laser": "sick"}, TypeError, "laser must be a LaserConfig"),
        ({"odometry": {"drift": 0.1}}, ValueError, "odometry has an unknown key 'drift'"),
        ({"no_return": "nan"}, ValueError, r"no_return must be one of \('max_range', 'inf'\)"),
        ({"world": "lawn"}, ValueError, "world='lawn' contradicts the env id"),
        ({"world": 3}, ValueError, "world must be 'hallway' or 'lawn'"),
        ({"world": "lawn:3"}, ValueError, "world='lawn:3' contradicts the env id"),
        ({"world": "hallway:x"}, ValueError, "FAMILY:SEED"),
        ({"world": "hallway:-2"}, ValueError, "FAMILY:SEED"),
    ],
)
def test_every_argument_is_checked_and_named(kwargs, error, match):
    with pytest.raises(error, match=match):
        gym.make("topomap/Hallway-v0", **kwargs)


def test_configs_as_dicts_and_the_ids_own_world():
    env = gym.make(
        "topomap/Lawn-v0",
        world="lawn",
        camera={"width": 64, "height": 48},
        laser={"beams": 91},
        odometry={"translation": 0.0},
    )
    obs, _ = env.reset(seed=0)
    assert obs["image"].shape == (48, 64, 3) and obs["scan"].shape == (91,)
    assert env.unwrapped.world_name == "lawn"
    assert env.spec.kwargs["camera"] == {"width": 64, "height": 48}  # a JSON spec
    env.spec.to_json()
    env.close()


@pytest.mark.parametrize(
    "options, error, match",
    [
        ([("pose", (5.0, 0.0, 0.0))], TypeError, "options must be a dict with keys from"),
        ({"poze": (5.0, 0.0, 0.0)}, ValueError, "unknown key 'poze'.*did you mean 'pose'"),
        ({"manifld": "lawn"}, ValueError, "did you mean 'manifold'"),
        ({"pose": (5.0, float("nan"), 0.0)}, ValueError, r"options\['pose'\] must be a finite"),
    ],
)
def test_reset_options_are_checked_and_named(options, error, match):
    env = gym.make("topomap/Lawn-v0", sensors=("scan",))
    with pytest.raises(error, match=match):
        env.reset(seed=0, options=options)
    env.close()


def test_generated_world_under_its_family_id():
    env = gym.make("topomap/Lawn-v0", world="lawn:3", sensors=("scan",), laser={"beams": 31})
    world = env.unwrapped.world
    assert env.unwrapped.world_name == "lawn:3" and world.name == "lawn:3"
    leaf = list(world.routes)[-1]
    _, info = env.reset(seed=0, options={"manifold": leaf})
    assert info["manifold"] == leaf and info["manifold_id"] == world.manifold_ids[leaf]
    _, _, _, truncated, info = env.step(np.array([0.2, 0.0]))
    assert info["manifold"] in world.manifold_names and not truncated
    with pytest.raises(ValueError, match="manifolds of 'lawn:3'"):
        env.reset(seed=0, options={"manifold": "lawn-left"})
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")  # the expected ones: see the canonical worlds' test
        check_env(env.unwrapped, skip_render_check=True)
    env.close()
