"""The benchmark protocol (tiers, splits, Wilson intervals, the runner's summary) and the
camera-only controller's units: localisation, route graph, waypoint tracking, steering."""

import numpy as np
import pytest

from scenes import MANIFOLDS
from servo.camera_only.controller import SignalServo, WaypointTracker
from servo.localise import ImageLocaliser
from servo.route import RouteGraph
from servo.task.env import ServoEnv
from servo.task.evaluation import signal_agreement, summarise
from servo.task.protocol import Protocol, episode_specs, reset_options
from servo.task.stats import wilson_interval


@pytest.fixture(scope="module")
def hallway_env(servo_maps):
    env = ServoEnv("hallway", servo_maps["hallway"], max_steps=200)
    yield env
    env.close()


def test_wilson_interval_closed_form():
    # Reference values (Wilson 1927; e.g. statsmodels proportion_confint(method="wilson")).
    np.testing.assert_allclose(wilson_interval(5, 10), (0.236593, 0.763407), atol=1e-6)
    np.testing.assert_allclose(wilson_interval(0, 10), (0.0, 0.277533), atol=1e-6)
    np.testing.assert_allclose(wilson_interval(20, 20), (0.838875, 1.0), atol=1e-6)
    with pytest.raises(ValueError, match="successes"):
        wilson_interval(3, 2)


def test_protocol_refuses_unknown_names():
    with pytest.raises(ValueError, match="tier must be one of"):
        Protocol("hallway", tier="nowhere")
    with pytest.raises(ValueError, match="split must be one of"):
        Protocol("hallway", split="train")
    with pytest.raises(ValueError, match="world must be 'hallway' or 'lawn'.*FAMILY:SEED"):
        Protocol("moon")


def test_episode_sets_are_deterministic_and_splits_disjoint(servo_maps):
    labels = servo_maps["hallway"].true_labels
    dev = episode_specs(Protocol("hallway", split="dev"), labels, 24)
    test = episode_specs(Protocol("hallway", split="test"), labels, 24)
    assert dev == episode_specs(Protocol("hallway", split="dev"), labels, 24)
    assert dev[:10] == episode_specs(Protocol("hallway", split="dev"), labels, 10)
    assert not {s.seed for s in dev} & {s.seed for s in test}
    # the tier does not change the episodes: tiers compare on the same tasks
    assert dev == episode_specs(Protocol("hallway", "anywhere", "dev"), labels, 24)
    pairs = {(s.start_manifold, s.target_manifold) for s in dev}
    assert all(a != b for a, b in pairs)
    assert ("hallway-left", "hallway") in pairs  # the main corridor is a target too
    assert len(pairs) == 12  # every ordered pair of the 4 manifolds
    with pytest.raises(ValueError, match="episodes"):
        episode_specs(Protocol("hallway"), labels, 0)


def test_anywhere_starts_lie_on_the_start_manifold(hallway_env, servo_maps):
    env = hallway_env
    for spec in episode_specs(Protocol("hallway", "anywhere", "dev"), env.map.true_labels, 6):
        options = reset_options(env, spec, "anywhere")
        again = reset_options(env, spec, "anywhere")  # from the episode's seed alone
        np.testing.assert_array_equal(options["pose"], again["pose"])
        _, info = env.reset(seed=spec.seed, options=options)
        assert info["start_manifold"] == spec.start_manifold
        assert info["target_manifold"] == spec.target_manifold
        np.testing.assert_allclose(info["pose"], options["pose"], atol=1e-9)
    with pytest.raises(ValueError, match=r"options\['pose'\].*not in free space"):
        env.reset(seed=0, options={"pose": (1e3, 1e3, 0.0), "target_manifold": "hallway"})
    with pytest.raises(ValueError, match="target"):
        env.reset(seed=0, options={"target": len(env.map)})


def test_summary_has_intervals_pairs_and_signal():
    def record(success, start="a", f=(0.1, 0.2, 0.3), d=(3.0, 2.0, 1.0)):
        return {
            "success": success,
            "spl": 0.8 * success,
            "final_distance": 0.3,
            "final_heading_error_deg": 5.0,
            "steps": 100,
            "collisions": 0,
            "reason": "success" if success else "time limit",
            "act_ms": 1.0,
            "start_manifold": start,
            "target_manifold": "b",
            "signal_target": np.array(f),
            "true_distance": np.array(d),
            "trail": np.zeros((3, 3)),
        }

    records = [record(True), record(False, "c", f=(0.3, 0.2, 0.1)), record(True)]
    s = summarise(records)
    assert s["successes"] == 2 and s["success_ci95"] == list(wilson_interval(2, 3))
    assert s["reasons"] == {"success": 2, "time limit": 1}
    assert s["per_pair"]["a -> b"]["success_rate"] == 1.0
    assert s["per_pair"]["c -> b"]["success_rate"] == 0.0
    assert "trail" not in s["episodes_detail"][0]
    sig = signal_agreement(records, lag=1)
    assert sig["pairs"] == 6 and sig["rises"] == pytest.approx(4 / 6)


def test_route_graph(servo_maps):
    m = servo_maps["hallway"]
    g = RouteGraph(m)
    left = int(np.flatnonzero(m.true_labels == MANIFOLDS.index("hallway-left"))[-1])
    right = int(np.flatnonzero(m.true_labels == MANIFOLDS.index("hallway-right"))[-1])
    route = g.route(left, right)
    assert route[0] == left and route[-1] == right
    waypoints, directions = g.waypoints(route, 0.8)
    assert waypoints[-1] == right and set(directions) == {-1, 1}  # back down left, on to right
    assert directions[0] == -1 and directions[-1] == 1
    frames = g.frames(route)
    gaps = np.hypot(*np.diff(frames[:, :2], axis=0).T)
    assert gaps.max() < 2.0
    with pytest.raises(ValueError, match="target"):
        g.route(left, len(m))
    with pytest.raises(ValueError, match="spacing"):
        g.waypoints(route, 0.0)


def test_image_alignment_gives_the_heading_error(hallway_env):
    env = hallway_env
    loc = ImageLocaliser(env.map)
    view = 60
    for turn in (-0.15, 0.15):
        pose = env.map.true_poses[view] + (0.0, 0.0, turn)
        obs, _ = env.reset(seed=0, options={"pose": pose, "target": 0})
        x = loc.features(obs["image"])
        _, yaw = loc.align(x, [view])
        assert np.sign(yaw[0]) == -np.sign(turn) and abs(yaw[0] + turn) < 0.08
        assert loc.signal(x, view) < loc.signal(env.map.features[view], view) == pytest.approx(1)
    with pytest.raises(ValueError, match=r"observation\['image'\] must have shape"):
        loc.features(np.zeros((60, 80, 3), np.uint8))
    with pytest.raises(ValueError, match=r"observation\['image'\] must be finite"):
        loc.features(np.full(env.map.image_shape, np.nan))


def test_waypoint_tracker_advances_when_f_overtakes():
    t = WaypointTracker([3, 4, 5], np.array([1, 1, 1]), np.array([0.8, 0.8, 0.8]), overrun=2.0)
    assert not t.update(0.5, 0.2, 0.1, 0.3, 0.1) and t.current == 3
    assert t.update(0.5, 0.6, 0.1, 0.3, 0.1) and t.current == 4
    assert not t.update(0.0, 0.0, 0.3, 0.4, 0.1)  # no signal: the better-aligned image decides
    assert t.update(0.0, 0.0, 0.4, 0.3, 0.1) and t.current == 5 and t.last
    t = WaypointTracker([3, 4], np.array([1, 1]), np.array([0.5, 0.5]), overrun=2.0)
    assert t.update(0.5, 0.1, 0.1, 0.3, 2.0)  # driven far past it: given up
    t.advance()  # at the last one: stays
    assert t.current == 4 and t.last
    with pytest.raises(ValueError, match="equally long"):
        WaypointTracker([3], np.array([1, 1]), np.array([1.0]), 2.0)


def test_signal_servo_bad_inputs(servo_maps):
    ctl = SignalServo(servo_maps["hallway"], world="hallway")
    obs = {"image": np.zeros((240, 320, 3), np.uint8), "odometry": np.zeros(3)}
    with pytest.raises(RuntimeError, match="reset"):
        ctl.act(obs)
    with pytest.raises(ValueError, match="target"):
        ctl.reset(len(servo_maps["hallway"]))
    ctl.reset(0)
    with pytest.raises(ValueError, match=r"observation\['image'\] must have shape"):
        ctl.act({**obs, "image": np.zeros((60, 80, 3), np.uint8)})
    with pytest.raises(ValueError, match=r"observation\['odometry'\]"):
        ctl.act({**obs, "odometry": np.array([0.0, np.nan, 0.0])})
    with pytest.raises(ValueError, match="missing 'odometry'"):
        ctl.act({"image": obs["image"]})
    with pytest.raises(ValueError, match="fitted on the 'hallway' world"):
        SignalServo(servo_maps["hallway"], world="lawn")


def test_signal_servo_localises_by_turning(hallway_env):
    """After its observing turn the controller has a route to the target from a stored view
    near where it stands (a rate over view-tier starts, never one episode)."""
    env = hallway_env
    ctl = SignalServo(env.map)
    specs = episode_specs(Protocol("hallway", "view", "dev"), env.map.true_labels, 3)
    near = 0
    for spec in specs:
        obs, info = env.reset(seed=spec.seed, options=reset_options(env, spec, "view"))
        ctl.reset(info["target_view"])
        while ctl.phase_ == "observe":
            obs, *_, info = env.step(ctl.act(obs))
        assert ctl.route_[-1] == info["target_view"] and ctl.waypoint_ is not None
        near += np.hypot(*(env.map.true_poses[ctl.route_[0], :2] - info["pose"][:2])) < 1.5
    assert near >= 2


def test_score_episode_is_a_function_of_the_infos_alone():
    from servo.task.evaluation import score_episode

    def info(x, **over):
        base = {
            "pose": np.array([x, 0.0, 0.0]),
            "signal": x / 4,
            "collision": False,
            "path_length": x,
            "success": False,
            "reason": None,
            "distance": 4 - x,
            "heading_error": 0.0,
            "start_manifold": "a",
            "target_manifold": "b",
            "target_view": 7,
            "target_pose": np.array([4.0, 0.0, 0.0]),
        }
        return {**base, **over}

    infos = [
        info(0.0),
        info(1.0, collision=True),
        info(2.0),
        info(5.0, success=True, reason="success", distance=0.1, heading_error=np.pi / 18),
    ]
    record = score_episode(3, infos, 4.0, [4, 3, 2, 0.1], [0.001, 0.003, 0.002], [np.nan] * 3)
    assert record["steps"] == 3 and record["collisions"] == 1 and record["success"]
    assert record["spl"] == pytest.approx(4.0 / 5.0)
    assert record["final_heading_error_deg"] == pytest.approx(10.0)
    assert record["act_ms"] == pytest.approx(2.0)
    np.testing.assert_array_equal(record["trail"][:, 0], [0, 1, 2, 5])
    np.testing.assert_array_equal(record["signal_target"], [0, 0.25, 0.5, 1.25])
    np.testing.assert_array_equal(record["start_pose"], [0, 0, 0])
    with pytest.raises(ValueError, match="infos must hold"):
        score_episode(3, infos[:1], 4.0, [4], [], [])
