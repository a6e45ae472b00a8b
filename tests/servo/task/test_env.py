import warnings

import numpy as np
import pytest
from gymnasium.utils.env_checker import check_env

from servo.maps.build import MapError, save_map
from servo.task.env import ServoEnv


@pytest.fixture(scope="module")
def env(servo_maps):
    e = ServoEnv("hallway", servo_maps["hallway"], max_steps=50)
    yield e
    e.close()


# check_env's advice the base env deliberately does not take (see tests/sim/test_env.py):
# (v, omega) keep their physical units, and odometry is unbounded.
EXPECTED_WARNINGS = (
    "symmetric and normalized space",
    "maximum value is infinity",
    "minimum value is -infinity",
)


def test_check_env(env):
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        check_env(env, skip_render_check=True)
    unexpected = [
        str(w.message) for w in caught if not any(e in str(w.message) for e in EXPECTED_WARNINGS)
    ]
    assert not unexpected


def test_cross_manifold_task_and_info(env):
    for seed in range(5):
        obs, info = env.reset(seed=seed)
        assert info["start_manifold"] != info["target_manifold"]
        assert obs["target_image"].shape == obs["image"].shape
        np.testing.assert_allclose(obs["odometry"], 0.0, atol=1e-12)
        assert info["distance"] > 0.5 and info["reason"] is None
    obs, r, _, _, info = env.step(np.array([0.5, 0.0], np.float32))
    assert {"reward_signal", "reward_success", "reward_collision"} <= set(info)
    assert r == pytest.approx(
        info["reward_signal"] + info["reward_success"] + info["reward_collision"]
    )


def test_deterministic_for_a_seed(env):
    def rollout():
        obs, _ = env.reset(seed=7)
        out = [obs]
        for k in range(5):
            obs, *_ = env.step(np.array([1.0, 0.3 * (-1) ** k], np.float32))
            out.append(obs)
        return out

    a, b = rollout(), rollout()
    for oa, ob in zip(a, b, strict=True):
        for key in oa:
            np.testing.assert_array_equal(oa[key], ob[key])


def test_success_terminates_at_the_target(env):
    m = env.map
    target = 40
    _, info = env.reset(seed=0, options={"target": target, "pose": m.true_poses[target]})
    assert info["success"]
    _, _, term, _, info = env.step(np.zeros(2, np.float32))
    assert term and info["reason"] == "success"


def test_step_limit_truncates(env):
    env.reset(seed=1)
    for _ in range(env.max_steps):
        _, _, term, trunc, info = env.step(np.zeros(2, np.float32))
    assert trunc and not term and info["reason"] == "time limit"


def test_pushing_a_wall_ends_as_stuck(servo_maps):
    e = ServoEnv("hallway", servo_maps["hallway"], max_steps=200)
    # Facing the end wall of the main hallway (x = 0), a few cm away from it.
    e.reset(seed=0, options={"pose": (0.5, 0.0, np.pi), "target": 100})
    for _ in range(200):
        _, _, term, trunc, info = e.step(np.array([1.0, 0.0], np.float32))
        if term or trunc:
            break
    e.close()
    assert term and info["reason"] == "stuck"


@pytest.mark.parametrize(
    "options, match",
    [
        ({"target": 99_999}, r"options\['target'\]"),
        ({"target_manifold": "kitchen"}, "manifold must be one of"),
        ({"start_view": -3}, r"options\['start_view'\]"),
        ({"target_manifold": "lawn-left"}, "the manifolds of the 'hallway' world.*'lawn-left'"),
    ],
)
def test_bad_options_are_named(env, options, match):
    with pytest.raises((ValueError, MapError), match=match):
        env.reset(seed=0, options=options)


def test_async_vector_env_spawn(servo_maps, tmp_path):
    from gymnasium.vector import AsyncVectorEnv

    path = save_map(servo_maps["hallway"], tmp_path)
    fns = [lambda: ServoEnv("hallway", str(path), max_steps=20)] * 2
    venv = AsyncVectorEnv(fns, context="spawn")
    try:
        obs, _ = venv.reset(seed=3)
        assert obs["image"].shape == (2, 240, 320, 3)
        obs, r, *_ = venv.step(np.tile(np.float32([0.5, 0.0]), (2, 1)))
        assert r.shape == (2,) and np.isfinite(r).all()
    finally:
        venv.close()


def test_registered_task_has_one_clock_and_takes_the_reward_weights(env, servo_maps, tmp_path):
    import gymnasium as gym
    from gymnasium.wrappers import TimeLimit

    made = gym.make(
        "topomap/HallwayServo-v0",
        servo_map=str(save_map(servo_maps["hallway"], tmp_path)),
        max_steps=70,
        signal_weight=2.0,
        collision_penalty=0.3,
    )
    try:
        # no TimeLimit of the registry on top of the env's own max_steps, which the spec says
        assert made.spec.max_episode_steps == 70 == made.unwrapped.spec.max_episode_steps
        made.spec.to_json()  # a map's path keeps the spec small and JSON
        wrapper = made
        while isinstance(wrapper, gym.Wrapper):
            assert not isinstance(wrapper, TimeLimit)
            wrapper = wrapper.env
        assert made.unwrapped.max_steps == 70
        # the same seed and actions drive the same episode; only the weighted parts change
        options = {"pose": (0.5, 0.0, np.pi), "target": 100}  # facing the end wall: contacts
        env.reset(seed=0, options=options)
        made.reset(seed=0, options=options)
        contacts = 0
        for _ in range(12):
            action = np.array([1.0, 0.0], np.float32)
            *_, a = env.step(action)
            _, r2, *_, b = made.step(action)
            np.testing.assert_array_equal(a["pose"], b["pose"])
            assert b["reward_signal"] == pytest.approx(2.0 * a["reward_signal"])
            assert b["reward_collision"] == pytest.approx(3.0 * a["reward_collision"])
            assert r2 == pytest.approx(b["reward_signal"] + b["reward_collision"])
            contacts += a["collision"]
        assert contacts > 0
    finally:
        made.close()


@pytest.mark.parametrize("name", ["signal_weight", "success_reward", "collision_penalty"])
def test_reward_weights_must_be_finite_numbers(servo_maps, name):
    with pytest.raises(ValueError, match=f"{name} must be a finite number"):
        ServoEnv("hallway", servo_maps["hallway"], **{name: float("nan")})


def test_options_that_contradict_cross_manifold_are_named(env):
    """A start manifold that is the target's leaves no start with cross_manifold=True: a
    ValueError saying so, not numpy's "high <= 0"."""
    left_view = int(np.flatnonzero(env.map.true_labels == 1)[0])  # MANIFOLDS[1]: hallway-left
    for options in (
        {"start_manifold": "hallway-left", "target_manifold": "hallway-left"},
        {"start_manifold": "hallway-left", "target": left_view},
    ):
        with pytest.raises(ValueError, match="conflict with cross_manifold=True"):
            env.reset(seed=0, options=options)


def test_a_map_with_no_other_manifold_to_target_is_named(env, servo_maps):
    """The target-less branch: every labelled view on the start pose's manifold."""
    import dataclasses

    m = servo_maps["hallway"]
    pose = m.true_poses[0]
    here = int(env.base.world.manifold_at(pose[:2]))
    labels = np.where(m.true_labels >= 0, here, -1).astype(m.true_labels.dtype)
    e = ServoEnv("hallway", dataclasses.replace(m, true_labels=labels), max_steps=5)
    try:
        with pytest.raises(ValueError, match="conflict with cross_manifold=True"):
            e.reset(seed=0, options={"pose": pose})
    finally:
        e.close()


@pytest.mark.parametrize(
    "pose", [None, 5.0, [[2.3, 0.0, 0.1]], "abc", [1j, 0, 0], [1.0, np.nan, 0.0], [[1], [2, 3]]]
)
def test_a_malformed_pose_option_is_named(env, pose):
    """Checked where the task is sampled from it, before NavigationEnv.reset would see it."""
    with pytest.raises(ValueError, match=r"options\['pose'\] must be a finite \(x, y, yaw\)"):
        env.reset(seed=0, options={"pose": pose})


@pytest.mark.parametrize("options", [[("pose", (2.3, 0.0, 0.1))], "target", 3])
def test_options_must_be_a_mapping(env, options):
    with pytest.raises(TypeError, match="options must be a dict"):
        env.reset(seed=0, options=options)


@pytest.fixture(scope="module")
def hallway_map_path(servo_maps, tmp_path_factory):
    return str(save_map(servo_maps["hallway"], tmp_path_factory.mktemp("map")))


def test_outer_time_limit_names_its_reason(hallway_map_path):
    import gymnasium as gym

    made = gym.make(
        "topomap/HallwayServo-v0", servo_map=hallway_map_path, max_episode_steps=3
    )  # a TimeLimit of 3 steps over the env's own 600
    try:
        assert made.spec.max_episode_steps == 3
        made.reset(seed=0)
        reasons = []
        for _ in range(3):
            *_, terminated, truncated, info = made.step(np.zeros(2, np.float32))
            reasons.append((terminated, truncated, info["reason"]))
        assert reasons == [(False, False, None)] * 2 + [(False, True, "time limit")]
    finally:
        made.close()


def test_a_map_object_given_to_make_warns_and_names_the_path_form(servo_maps):
    import gymnasium as gym

    with pytest.warns(UserWarning, match="pass the path of a saved map instead"):
        made = gym.make("topomap/HallwayServo-v0", servo_map=servo_maps["hallway"])
    made.close()
    with warnings.catch_warnings():
        warnings.simplefilter("error")  # a direct ServoEnv(map) has no spec: no warning
        ServoEnv("hallway", servo_maps["hallway"], max_steps=5).close()


@pytest.mark.parametrize("env_id", ["topomap/HallwayServo-v0", "topomap/LawnServo-v0"])
def test_check_env_and_bounded_finite_observations(env_id, servo_maps, tmp_path):
    import gymnasium as gym
    from gymnasium.wrappers import FlattenObservation, NormalizeObservation

    world = "hallway" if "Hallway" in env_id else "lawn"
    path = str(save_map(servo_maps[world], tmp_path))
    made = gym.make(env_id, servo_map=path, max_steps=8)
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        check_env(made.unwrapped, skip_render_check=True)
    assert not [w for w in caught if not any(e in str(w.message) for e in EXPECTED_WARNINGS)]
    space, max_range = made.observation_space, made.unwrapped.base.laser_config.max_range
    misses = 0
    for seed in range(3):
        obs, _ = made.reset(seed=seed)
        made.action_space.seed(seed)
        done = False
        while not done:
            assert space.contains(obs)
            assert all(np.isfinite(v).all() for v in obs.values())
            for key in ("scan", "target_scan"):
                np.testing.assert_array_equal(obs[key][obs[f"{key}_valid"] == 0], max_range)
                misses += int((obs[f"{key}_valid"] == 0).sum())
            obs, _, terminated, truncated, _ = made.step(made.action_space.sample())
            done = terminated or truncated
    assert misses > 0
    made.close()
    flat = NormalizeObservation(FlattenObservation(gym.make(env_id, servo_map=path)))
    obs, _ = flat.reset(seed=0)
    for _ in range(3):
        obs, reward, *_ = flat.step(np.array([0.5, 0.2], np.float32))
        assert np.isfinite(obs).all() and np.isfinite(reward)
    flat.close()


def test_no_return_inf_keeps_the_raw_ranges(env, servo_maps):
    raw = ServoEnv("hallway", servo_maps["hallway"], max_steps=50, no_return="inf")
    try:
        assert set(raw.observation_space) == {
            "image",
            "scan",
            "odometry",
            "target_image",
            "target_scan",
        }
        assert raw.observation_space["scan"].high.max() == np.inf
        obs_raw, _ = raw.reset(seed=4)
        obs, _ = env.reset(seed=4)
        for key in ("scan", "target_scan"):
            returned = np.isfinite(obs_raw[key])
            np.testing.assert_array_equal(obs[f"{key}_valid"], returned)
            np.testing.assert_array_equal(obs[key][returned], obs_raw[key][returned])
        np.testing.assert_array_equal(obs_raw["target_scan"], env.map.scans[env._target])
    finally:
        raw.close()


@pytest.mark.parametrize(
    "kwargs, match",
    [
        ({"world": "lawn", "registered_world": "hallway"}, "world='lawn' contradicts the env id"),
        ({"cross_manifold": "no"}, "cross_manifold must be True or False"),
        ({"odometry_noise": 0}, "odometry_noise must be True or False"),
        ({"randomize": None}, "randomize must be True or False"),
        ({"max_steps": 2.5}, "max_steps must be an integer"),
        ({"no_return": None}, "no_return must be one of"),
    ],
)
def test_every_argument_is_checked_and_named(servo_maps, kwargs, match):
    kwargs = {"world": "hallway", **kwargs}
    with pytest.raises(ValueError, match=match):
        ServoEnv(servo_map=servo_maps["hallway"], **kwargs)


def test_a_world_contradicting_the_id_is_refused(hallway_map_path):
    import gymnasium as gym

    with pytest.raises(ValueError, match="world='lawn' contradicts the env id"):
        gym.make("topomap/HallwayServo-v0", world="lawn", servo_map=hallway_map_path)


@pytest.mark.parametrize(
    "options, match",
    [({"targt": 3}, "did you mean 'target'"), ({"start_manifol": "x"}, "'start_manifold'")],
)
def test_unknown_reset_options_are_named(env, options, match):
    with pytest.raises(ValueError, match=match):
        env.reset(seed=0, options=options)


# The success test's two thresholds, SUCCESS_RADIUS = 0.5 m and SUCCESS_HEADING = 20 deg, each
# probed just inside and just outside with the other condition met: dropping either condition or
# moving either threshold by more than the margin fails one of these cases.
@pytest.mark.parametrize(
    "along, yaw_deg, success",
    [
        (0.48, 0.0, True),  # just inside the radius
        (-0.48, 0.0, True),
        (0.52, 0.0, False),  # just outside it
        (-0.52, 0.0, False),
        (0.0, 19.0, True),  # just inside the heading
        (0.0, -19.0, True),
        (0.0, 21.0, False),  # just outside it
        (0.0, -21.0, False),
        (0.48, 19.0, True),  # both just inside
        (0.48, 21.0, False),  # in the radius, out of the heading
    ],
)
def test_success_radius_and_heading_at_their_edges(env, along, yaw_deg, success):
    from servo.task.env import SUCCESS_HEADING, SUCCESS_RADIUS

    assert SUCCESS_RADIUS == 0.5 and SUCCESS_HEADING == pytest.approx(np.deg2rad(20.0))
    target = 40
    x, y, yaw = env.map.true_poses[target]
    # along the target's heading (the corridor), so the start pose stays in free space
    pose = np.array([x + along * np.cos(yaw), y + along * np.sin(yaw), yaw + np.deg2rad(yaw_deg)])
    _, info = env.reset(seed=0, options={"target": target, "pose": pose})
    assert info["distance"] == pytest.approx(abs(along), abs=1e-3)
    assert info["heading_error"] == pytest.approx(np.deg2rad(abs(yaw_deg)), abs=1e-3)
    assert info["success"] is success
    _, reward, term, _, info = env.step(np.zeros(2, np.float32))
    assert info["success"] is success and term is success
    assert info["reward_success"] == (env.success_reward if success else 0.0)
    assert reward == pytest.approx(info["reward_signal"] + info["reward_success"])
    assert info["reason"] == ("success" if success else None)
