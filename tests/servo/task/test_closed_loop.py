"""Real episodes, scored as rates: the controller and the oracle over seeded cross-manifold
tasks in both worlds, each asserted with a margin below the rate measured (docs/guides/servo.md), so
a test never pins one episode's outcome. Closed-loop outcomes are per machine: a last-bit change in
BLAS or in Mesa's JIT-compiled rasteriser can flip a near tie and with it an episode (see
docs/guides/servo.md, "Determinism"); the same seed gives the same episode on one machine."""

import numpy as np
import pytest

from servo.laser_image.controller import ManifoldServo
from servo.task.baseline_policies import GreedyFProbing, OraclePolicy, RandomPolicy
from servo.task.env import ServoEnv
from servo.task.evaluation import episode_seeds, run_episode
from servo.task.protocol import Protocol, episode_specs, reset_options

EPISODES = 6  # per world and policy
# Least successes of EPISODES asserted: 5 of 6 for both policies (6 of 6 is measured on these
# seeds in both worlds). The rates and the binomial chances behind the level are in the
# docstrings of the two tests below.
MIN_SUCCESSES = {"servo": 5, "oracle": 5}
TEST_SEED = 11


@pytest.fixture(scope="module")
def envs(servo_maps):
    out = {w: ServoEnv(w, m, max_steps=500) for w, m in servo_maps.items()}
    yield out
    for e in out.values():
        e.close()


def _policy(name, env):
    if name == "servo":
        return ManifoldServo(env.map, world=env.map.world)
    return OraclePolicy(env.base.world)


@pytest.mark.parametrize("policy", ["servo", "oracle"])
@pytest.mark.parametrize("world", ["hallway", "lawn"])
def test_success_rate_over_seeded_tasks(envs, world, policy):
    """At least 5 of 6 seeded cross-manifold tasks reached, with an SPL above 0.5.

    Measured rates, on this test's seeds extended to 30 (``episode_seeds(11, 30)``, the first 6
    of which are the test's: 6/6 for both policies in both worlds): ``ManifoldServo`` 29/30 in
    the hallway and 30/30 in the lawn, the oracle 30/30 in both; ``ManifoldServo`` on the
    protocol's 100 test episodes of the same tier: 96/100 in the hallway, 100/100 in the lawn
    (docs/results/servo.md). False alarm (binomial, 4 or fewer successes in 6 where the
    episodes flip from machine to machine as draws at the measured rate): 2.0 % at the
    hallway's pooled 125/130, 1.3 % at 31/32 (Laplace's estimate after 30/30, the oracle
    and the lawn). A regression to a true rate of 0.7 passes one world with probability 0.42
    and both with 0.18; at 0.5, 0.11 and 0.01 (4/6, the former level, passed 0.74 and 0.34).
    """
    env = envs[world]
    pol = _policy(policy, env)
    truth = policy == "oracle"  # the runner gives the truth to the oracle alone
    records = [run_episode(env, pol, s, truth=truth) for s in episode_seeds(TEST_SEED, EPISODES)]
    assert all(r["start_manifold"] != r["target_manifold"] for r in records)
    successes = sum(r["success"] for r in records)
    summary = [(r["start_manifold"], r["target_manifold"], r["reason"]) for r in records]
    assert successes >= MIN_SUCCESSES[policy], summary
    assert np.mean([r["spl"] for r in records if r["success"]]) > 0.5


@pytest.mark.parametrize("world", ["hallway", "lawn"])
def test_servo_from_anywhere(envs, world):
    """The protocol's ``anywhere`` tier (uniform in the start manifold's free space, any
    heading), its test split's first 6 episodes: at least 5 reached.

    Measured 6/6 in both worlds; on the tier's 100 test episodes, of which these are the first
    (docs/results/servo.md), 96/100 in the hallway and 99/100 in the lawn. False alarm
    (binomial, 4 or fewer in 6 at those rates): 2.2 % in the hallway, 0.15 % in the lawn. A
    regression to a true rate of 0.7 passes one world with probability 0.42, both with 0.18.
    """
    env = envs[world]
    env.max_steps = 600
    pol = ManifoldServo(env.map, world=world)
    specs = episode_specs(Protocol(world, "anywhere", "test"), env.map.true_labels, EPISODES)
    try:
        records = [run_episode(env, pol, s.seed, reset_options(env, s, "anywhere")) for s in specs]
    finally:
        env.max_steps = 500
    summary = [(r["start_manifold"], r["target_manifold"], r["reason"]) for r in records]
    assert sum(r["success"] for r in records) >= MIN_SUCCESSES["servo"], summary


def test_controller_is_deterministic(envs):
    env = envs["lawn"]

    def actions():
        obs, info = env.reset(seed=5)
        ctl = ManifoldServo(env.map)
        ctl.reset(info["target_view"])
        out = []
        for _ in range(25):
            out.append(ctl.act(obs))
            obs, *_ = env.step(out[-1])
        return np.array(out)

    np.testing.assert_array_equal(actions(), actions())


def test_controller_acts_alike_on_the_masked_and_the_raw_scans(envs, servo_maps):
    """The default observation (no return at the maximum range, flagged by scan_valid) and
    no_return="inf" drive the same actions, step for step, on the lawn's open ground."""
    env = envs["lawn"]
    raw = ServoEnv("lawn", servo_maps["lawn"], max_steps=500, no_return="inf")
    try:
        obs, info = env.reset(seed=5)
        obs_raw, _ = raw.reset(seed=5)
        a, b = ManifoldServo(env.map), ManifoldServo(env.map)
        a.reset(info["target_view"])
        b.reset(info["target_view"])
        misses = 0
        for _ in range(25):
            misses += int(np.isinf(obs_raw["scan"]).sum())
            action = a.act(obs)
            np.testing.assert_array_equal(action, b.act(obs_raw))
            obs, *_ = env.step(action)
            obs_raw, *_ = raw.step(action)
        assert misses > 0
        with pytest.raises(ValueError, match=r"observation\['scan_valid'\] must have shape"):
            a.act({**obs, "scan_valid": obs["scan_valid"][:10]})
    finally:
        raw.close()


def test_controller_needs_no_truth(envs):
    """act() never reads info: poisoning it changes nothing."""
    env = envs["hallway"]
    obs, info = env.reset(seed=2)
    a, b = ManifoldServo(env.map), ManifoldServo(env.map)
    a.reset(info["target_view"])
    b.reset(info["target_view"], {"pose": np.full(3, np.nan)})
    np.testing.assert_array_equal(a.act(obs), b.act(obs, {"pose": np.full(3, np.nan)}))


def test_controller_bad_inputs(servo_maps):
    ctl = ManifoldServo(servo_maps["hallway"])
    obs = {
        "image": np.zeros((240, 320, 3), np.uint8),
        "scan": np.ones(361, np.float32),
        "odometry": np.zeros(3),
    }
    with pytest.raises(RuntimeError, match="reset"):
        ctl.act(obs)
    with pytest.raises(ValueError, match="target"):
        ctl.reset(len(servo_maps["hallway"]))
    ctl.reset(0)
    with pytest.raises(ValueError, match=r"observation\['image'\] must have shape"):
        ctl.act({**obs, "image": np.zeros((60, 80, 3), np.uint8)})
    with pytest.raises(ValueError, match=r"observation\['scan'\]"):
        ctl.act({**obs, "scan": np.ones(180, np.float32)})
    with pytest.raises(ValueError, match="odometry"):
        ctl.act({k: v for k, v in obs.items() if k != "odometry"})
    with pytest.raises(ValueError, match=r"observation\['scan'\] must not hold NaN"):
        ctl.act({**obs, "scan": np.full(361, np.nan, np.float32)})
    with pytest.raises(ValueError, match="odometry"):
        ctl.act({**obs, "odometry": np.array([0.0, np.nan, 0.0])})


def test_baselines_run(envs):
    env = envs["hallway"]
    for policy in (GreedyFProbing(env.map), RandomPolicy(np.random.default_rng(0))):
        obs, info = env.reset(seed=4)
        policy.reset(info["target_view"], info)
        for _ in range(15):
            a = policy.act(obs, info)
            assert env.action_space.contains(np.asarray(a, np.float32))
            obs, _, _, _, info = env.step(a)


def test_arrival_radius():
    """The arrival law stops driving within its radius (the controller's ``arrive_radius``)."""
    from servo.steering import Arrival

    near = np.array([0.15, 0.0, 0.0])
    assert Arrival(0.2)(near)[0] == 0.0  # within 0.2 m: turns (already facing: done)
    assert Arrival(0.1)(near)[0] > 0.0  # not within 0.1 m: drives on
    with pytest.raises(ValueError, match="radius"):
        Arrival(0.5)


def test_the_stall_window_sees_commanded_motion_that_odometry_does_not():
    from servo.steering import StallWindow
    from sim.simulator import CONTROL_DT

    w = StallWindow(10)
    moving = [(0.5 * CONTROL_DT * i, 0.0, 0.0) for i in range(10)]
    assert not any(w.stalled(0.5, odo) for odo in moving)  # moved as commanded
    w.clear()
    jitter = [(0.001 * (i % 2), 0.0, 0.0) for i in range(10)]
    assert [w.stalled(0.5, odo) for odo in jitter] == [False] * 9 + [True]
    w.clear()
    assert not any(w.stalled(0.0, odo) for odo in jitter)  # nothing commanded


BAD_IMAGES = [  # (image from a good one, error, match)
    (lambda im: np.full(im.shape, -5.0), ValueError, r"in \[0, 255\], got values in \[-5"),
    (lambda im: np.full(im.shape, 10**6), ValueError, r"in \[0, 255\]"),
    (lambda im: im.astype(float) + 255.5, ValueError, r"in \[0, 255\]"),
    (lambda im: np.full(im.shape, "a"), TypeError, "must hold real numbers"),
    (lambda im: im.astype(object), TypeError, "must hold real numbers"),
    (lambda im: im > 0, TypeError, "must hold real numbers"),
    (lambda im: im.astype(complex), TypeError, "must hold real numbers"),
]


@pytest.mark.parametrize("policy", ["servo", "signal", "greedy"])
def test_controllers_refuse_images_that_are_not_pixels(servo_maps, policy):
    """Negative, > 255, str, object, bool or complex images were acted on as pixels (or failed
    in a ufunc); the shared check names observation['image']."""
    from servo.camera_only.controller import SignalServo

    m = servo_maps["hallway"]
    ctl = {"servo": ManifoldServo, "signal": SignalServo, "greedy": GreedyFProbing}[policy](m)
    ctl.reset(0)
    obs = {"image": m.images[0], "scan": m.scans[0].copy(), "odometry": np.zeros(3)}
    for make, error, match in BAD_IMAGES:
        with pytest.raises(error, match=r"observation\['image'\] .*" + match):
            ctl.act({**obs, "image": make(m.images[0])})


def test_float_pixels_are_still_images(servo_maps):
    """Float images in [0, 1] (what ImageFeatures documents for floats) and the bounds of
    [0, 255] themselves are not refused."""
    from servo.localise import ImageLocaliser

    m = servo_maps["hallway"]
    loc = ImageLocaliser(m)
    image = m.images[7]
    np.testing.assert_allclose(loc.features(image / 255.0), loc.features(image), atol=1e-5)
    loc.features(np.zeros(m.image_shape, np.int64))
    loc.features(np.full(m.image_shape, 255.0))


@pytest.mark.parametrize("value", [-1.0, -np.inf])
def test_controller_refuses_negative_ranges(servo_maps, value):
    m = servo_maps["hallway"]
    ctl = ManifoldServo(m)
    ctl.reset(0)
    scan = m.scans[0].copy()
    scan[5] = value
    obs = {"image": m.images[0], "scan": scan, "odometry": np.zeros(3)}
    with pytest.raises(ValueError, match=r"observation\['scan'\] must hold ranges >= 0"):
        ctl.act(obs)
    scan[5] = np.inf  # no return: a range like any other
    ctl.act(obs)


def test_baselines_refuse_bad_use(envs):
    env = envs["hallway"]
    obs, info = env.reset(seed=3)
    for policy in (GreedyFProbing(env.map), OraclePolicy(env.base.world)):
        with pytest.raises(RuntimeError, match=r"call reset\(.*\) before act"):
            policy.act(obs, info)
    greedy = GreedyFProbing(env.map)
    greedy.reset(info["target_view"])
    with pytest.raises(ValueError, match="observation is missing 'image'"):
        greedy.act({"scan": obs["scan"]})
    with pytest.raises(ValueError, match="observation must be a dict, got NoneType"):
        greedy.act(None)
    for hold in (0, -1, 1.5, "5"):
        with pytest.raises(ValueError, match="hold must be an integer >= 1"):
            RandomPolicy(np.random.default_rng(0), hold=hold)
    for bad in (
        dict(speed=float("nan")),
        dict(speed=0.0),
        dict(lookahead=-1.0),
        dict(lookahead=float("inf")),
        dict(speed="x"),
    ):
        name = next(iter(bad))
        with pytest.raises(ValueError, match=f"{name} must be a finite number"):
            OraclePolicy(env.base.world, **bad)
