"""Outside policies on the servo benchmark: the truth boundary (what a policy is given), the
failures that end an episode with a reason while the run goes on, and the command line."""

import json
import time

import numpy as np
import pytest

from scenes import NO_MANIFOLD
from servo.task.env import ServoEnv
from servo.task.evaluation import make_policy, run_episode
from servo.task.guard import INVALID_ACTION, NOT_LOADED, RAISED, TOO_SLOW
from servo.task.interface import (
    PolicyLoadError,
    Target,
    load_factory,
    make_outside_policy,
    sensed_map,
)
from servo.task.protocol import Protocol, run_protocol

HERE = __name__  # this module, importable as the runner imports a user's module
SEEN: list = []  # what the spy policy was given, call by call


def _forbidden(obj, depth: int = 0, seen=None) -> list[str]:
    """Names of the objects reachable from ``obj`` (containers, attributes, array bases) that
    would lead to the truth: an env, a simulator, a world or MuJoCo's model and data."""
    seen = set() if seen is None else seen
    if id(obj) in seen or depth > 4:
        return []
    seen.add(id(obj))
    kind = type(obj)
    found = [kind.__name__] if kind.__module__.split(".")[0] in ("mujoco", "gymnasium") else []
    if kind.__name__ in ("ServoEnv", "NavigationEnv", "Simulator", "World", "GeodesicField"):
        found.append(kind.__name__)
    children = []
    if isinstance(obj, dict):
        children = list(obj.values())
    elif isinstance(obj, list | tuple):
        children = list(obj)
    elif isinstance(obj, np.ndarray):
        children = [] if obj.base is None else [obj.base]
    elif hasattr(obj, "__dict__") and not isinstance(obj, type):
        children = list(vars(obj).values())
    for child in children:
        found += _forbidden(child, depth + 1, seen)
    return found


class Spy:
    """Records every argument it is given."""

    def __init__(self, servo_map, rng):
        SEEN.append(("factory", servo_map, rng))

    def reset(self, *args):
        SEEN.append(("reset", *args))

    def act(self, *args):
        SEEN.append(("act", *args))
        return np.array([0.3, 0.2], np.float32)


def spy(servo_map, rng):
    return Spy(servo_map, rng)


class Faulty:
    """Fails as ``how`` says on its ``at``-th act."""

    def __init__(self, how: str, at: int = 2):
        self.how, self.at = how, at

    def reset(self, target):
        self.n = 0

    def act(self, observation):
        self.n += 1
        if self.n < self.at:
            return np.zeros(2, np.float32)
        if self.how == "raise":
            raise RuntimeError("lost")
        if self.how == "slow":
            time.sleep(60.0)  # interrupted by the limit, long before it ends
        return {
            "nan": np.array([np.nan, 0.0]),
            "range": np.array([3.0, 0.0]),
            "shape": np.zeros(3),
            "text": "forward",
        }.get(self.how, np.zeros(2))


def faulty(servo_map, rng, how="raise", at=2):
    return Faulty(how, at)


def not_a_policy(servo_map, rng):
    return object()


def failing_factory(servo_map, rng):
    raise KeyError("no such view")


@pytest.fixture(scope="module")
def env(servo_maps):
    env = ServoEnv("hallway", servo_maps["hallway"], max_steps=6)
    yield env
    env.close()


def test_a_policy_is_given_no_truth(env, servo_maps):
    SEEN.clear()
    # what the factory is given, made here to be seen (the runner makes it in its own process)
    policy = make_outside_policy(f"{HERE}:spy", env.map, np.random.default_rng(0))
    record = run_episode(env, policy, seed=3)
    assert record["steps"] == 6 and "failure" not in record
    (_, m, rng), (_, target), *acts = SEEN
    # the map: sensed recordings only, its evaluation-only arrays blanked and read-only
    assert np.isnan(m.true_poses).all() and (m.true_labels == NO_MANIFOLD).all()
    assert not m.images.flags.writeable and not m.true_poses.flags.writeable
    np.testing.assert_array_equal(m.clusters, servo_maps["hallway"].clusters)
    assert isinstance(rng, np.random.Generator)
    # the target: a stored view's index and image, no pose
    assert isinstance(target, Target) and set(vars(target)) == {"view", "image"}
    np.testing.assert_array_equal(target.image, servo_maps["hallway"].images[target.view])
    # every act: the observation only, no info, nothing reaching the env
    assert len(acts) == 6 and all(len(a) == 2 for a in acts)
    assert all(set(a[1]) == set(env.observation_space.spaces) for a in acts)
    np.testing.assert_allclose(acts[0][1]["odometry"], np.zeros(3), atol=1e-9)  # from the start
    assert _forbidden([m, rng, target, *[a[1] for a in acts]]) == []
    # while the env's own map keeps its truth
    assert np.isfinite(env.map.true_poses).all()


def test_sensed_map_keeps_what_was_sensed(servo_maps):
    m = servo_maps["lawn"]
    s = sensed_map(m)
    for name in ("images", "features", "scans", "poses", "clusters", "edges", "edge_transforms"):
        np.testing.assert_array_equal(getattr(s, name), getattr(m, name))
    assert s.key != m.key and s.clustering is m.clustering  # the key names the map's file
    assert np.isnan(s.true_poses).all() and (s.true_labels == NO_MANIFOLD).all()


def test_only_the_oracle_is_given_the_truth_and_by_name(env):
    oracle = make_policy("oracle", env, np.random.default_rng(0))
    # run as any other policy, it is given no info: its reset fails, and so its episode
    record = run_episode(env, oracle, seed=3)
    assert record["reason"] == RAISED and "target_pose" in record["failure"]
    assert not record["success"]
    record = run_episode(env, oracle, seed=3, truth=True)
    assert "failure" not in record and record["steps"] > 0
    # our controllers run on the sensed map too
    servo = make_policy("greedy", env, np.random.default_rng(0))
    assert np.isnan(servo.map.true_poses).all()


@pytest.mark.parametrize(
    ("how", "reason", "says"),
    [
        ("raise", RAISED, "RuntimeError: lost"),
        ("nan", INVALID_ACTION, "not finite"),
        ("range", INVALID_ACTION, "outside"),
        ("shape", INVALID_ACTION, "shape (3,)"),
        ("text", INVALID_ACTION, "not numbers"),
        ("slow", TOO_SLOW, "within 0.2 s"),
    ],
)
def test_a_failing_policy_fails_its_episode_with_the_reason(env, how, reason, says):
    policy = make_policy(f"{HERE}:faulty", env, np.random.default_rng(0), how=how)
    t0 = time.perf_counter()
    try:  # in its own process: the boundary reports what went wrong there
        record = run_episode(env, policy, seed=3, act_limit_s=0.2)
    finally:
        policy.close()
    assert time.perf_counter() - t0 < 30.0  # a slow step is cut short, not waited out
    assert record["reason"] == reason and says in record["failure"]
    assert not record["success"] and record["steps"] == 1  # the first act went through


@pytest.mark.parametrize(
    ("spec", "says"),
    [
        ("no_such_package.policy:make", "does not import"),
        (f"{HERE}:missing", "has no callable 'missing'"),
        (f"{HERE}:not_a_policy", "lacks reset(target) and act(observation)"),
        (f"{HERE}:failing_factory", "the factory raised KeyError"),
    ],
)
def test_a_policy_that_cannot_be_made_is_named(env, spec, says):
    with pytest.raises(PolicyLoadError, match=says.replace("(", r"\(").replace(")", r"\)")):
        make_policy(spec, env, np.random.default_rng(0))


def test_the_run_goes_on_past_failing_episodes(servo_maps):
    protocol = Protocol("hallway", split="dev", max_steps=4)
    # the factory itself, as its import path
    r = run_protocol(
        protocol,
        servo_maps["hallway"],
        3,
        faulty,
        workers=1,
        progress=False,
        policy_options={"how": "nan", "at": 3},
    )
    assert r["episodes"] == 3 and r["reasons"] == {INVALID_ACTION: 3}
    assert r["policy"] == f"{HERE}:faulty" and r["policy_params"] == {"how": "nan", "at": 3}
    assert [e["steps"] for e in r["episodes_detail"]] == [2, 2, 2]
    r = run_protocol(
        protocol, servo_maps["hallway"], 2, "no_such_package.policy:make", workers=1, progress=False
    )
    assert r["reasons"] == {NOT_LOADED: 2}
    assert all("does not import" in e["failure"] for e in r["episodes_detail"])


def test_an_outside_policy_draws_the_same_per_episode_whatever_ran_before(servo_maps, tmp_path):
    from servo.maps import save_map
    from servo.task import protocol as runner
    from servo.task import worker

    protocol = Protocol("hallway", split="dev", max_steps=40)
    spec, params = "examples.image_descent:make_policy", {"patience": 1}  # tumbles often
    path = str(save_map(servo_maps["hallway"], tmp_path))
    both = run_protocol(protocol, path, 2, spec, workers=1, progress=False, policy_options=params)
    # episode 1 alone, in a fresh worker that never ran episode 0 (as in a pool of workers)
    specs = runner.episode_specs(protocol, servo_maps["hallway"].true_labels, 2)
    worker.init_worker(protocol, path, spec, params, reset_options=runner.reset_options)
    try:
        alone = worker.run_spec(specs[1])
    finally:
        worker.close_worker()
    keys = ("steps", "reason", "path_length", "final_distance", "collisions")
    assert {k: alone[k] for k in keys} == {k: both["episodes_detail"][1][k] for k in keys}
    assert alone["path_length"] > 0


def test_load_factory_imports_like_python_m():
    assert load_factory(f"{HERE}:spy") is spy
    for spec in (":spy", "no colon", f"{HERE}:spy:twice", f"{HERE}:not an identifier"):
        with pytest.raises(PolicyLoadError, match="package.module:factory"):
            load_factory(spec)
    with pytest.raises(ValueError, match="or package.module:factory"):
        make_policy("no colon", None, np.random.default_rng(0))


def test_servo_eval_runs_an_outside_policy_and_compares_it(
    servo_dataset, map_cache, tmp_path, capsys
):
    from scripts.cli import main

    common = [
        "--world",
        "hallway",
        "--episodes",
        "2",
        "--max-steps",
        "5",
        "--workers",
        "1",
        "--data",
        str(servo_dataset),
        "--maps",
        str(map_cache),
    ]
    assert main(["servo-eval", *common, "--policy", "random", "--out", str(tmp_path / "a")]) == 0
    assert (
        main(
            [
                "servo-eval",
                *common,
                "--policy",
                "examples.image_descent:make_policy",
                "--policy-arg",
                "speed=0.4",
                "--policy-arg",
                "patience=3",
                "--out",
                str(tmp_path / "b"),
            ]
        )
        == 0
    )
    (a,) = (tmp_path / "a").glob("*.json")
    (b,) = (tmp_path / "b").glob("*.json")
    result = json.loads(b.read_text())["results"][0]  # inside the result file's envelope
    assert result["policy"] == "examples.image_descent:make_policy"
    assert result["policy_params"] == {"speed": 0.4, "patience": 3}
    assert "image_descent" in b.name and ":" not in b.name
    capsys.readouterr()
    assert main(["servo-compare", str(a), str(b)]) == 0
    assert "examples.image_descent:make_policy" in capsys.readouterr().out
    with pytest.raises(SystemExit):
        main(["servo-eval", *common, "--policy", "not a module"])
    with pytest.raises(SystemExit):
        main(["servo-eval", *common, "--policy", "random", "--policy-arg", "speed"])


def test_chosen_episode_indices_are_the_protocols_episodes(servo_maps):
    protocol = Protocol("hallway", split="dev", max_steps=4)
    first = run_protocol(protocol, servo_maps["hallway"], 3, "random", workers=1, progress=False)
    chosen = run_protocol(
        protocol, servo_maps["hallway"], 1, "random", workers=1, progress=False, indices=[2, 0]
    )
    ends = {e["episode"]: e["seed"] for e in first["episodes_detail"]}
    assert [(e["episode"], e["seed"]) for e in chosen["episodes_detail"]] == [
        (2, ends[2]),
        (0, ends[0]),
    ]
    for bad in ([], [1, 1], [-1], [0.5], "01", 3, [True]):
        with pytest.raises(ValueError, match="indices must be a list of distinct integers"):
            run_protocol(
                protocol, servo_maps["hallway"], 1, "random", workers=1, progress=False, indices=bad
            )
