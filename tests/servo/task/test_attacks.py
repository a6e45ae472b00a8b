"""The attacks on the benchmark's truth boundary, as policies (``tests.servo.task.attacks``):
one walks the stack, one searches ``gc``, one follows the map's names and indices to the
recordings on disk, one scans the disk for map files. In the policy's own process each finds
nothing and drives exactly as a blind policy, on the test split, with and without the
sandbox (the disk scanner: with it); run in the evaluator's process, the first two find the
truth, which is why the process boundary is there."""

from pathlib import Path

import numpy as np
import pytest

from servo.task.env import ServoEnv
from servo.task.evaluation import run_episode
from servo.task.guard import RAISED
from servo.task.interface import make_outside_policy
from servo.task.protocol import Protocol, episode_specs, reset_options, run_protocol
from servo.task.remote import RemotePolicy, sandbox_tool
from tests.servo.task import attacks

ATTACKS = "tests.servo.task.attacks"
KEYS = ("steps", "reason", "path_length", "final_distance", "collisions", "success")
SANDBOX = [
    False,
    pytest.param(
        True,
        marks=pytest.mark.skipif(
            sandbox_tool() is None, reason="neither bwrap nor unshare makes a sandbox here"
        ),
    ),
]


@pytest.fixture(scope="module")
def task(generated_servo_map):
    m, cache = generated_servo_map
    env = ServoEnv("lawn:3", m, max_steps=4)
    (spec,) = episode_specs(Protocol("lawn:3", split="test"), m.true_labels, 1, m.manifold_names)
    yield env, spec, str(cache.parent)  # the folder of the run's datasets and maps
    env.close()


def _episode(task, name, sandbox, **params):
    env, spec, data = task
    policy = RemotePolicy(f"{ATTACKS}:{name}", env.map, params=params, sandbox=sandbox, hide=[data])
    try:
        return run_episode(env, policy, spec.seed, reset_options(env, spec, "view"))
    finally:
        policy.close()


@pytest.fixture(scope="module")
def blind(task):
    return _episode(task, "blind", False)


@pytest.mark.parametrize("sandbox", SANDBOX)
@pytest.mark.parametrize("name", ["stack_walker", "gc_searcher", "recordings_opener"])
def test_an_attack_finds_nothing_and_drives_blind(task, blind, name, sandbox):
    params = {"roots": [task[2]]} if name == "recordings_opener" else {}
    record = _episode(task, name, sandbox, **params)
    assert "failure" not in record, record.get("failure")
    assert {k: record[k] for k in KEYS} == {k: blind[k] for k in KEYS}


@pytest.mark.skipif(sandbox_tool() is None, reason="no sandbox here")
def test_the_sandbox_hides_the_maps_and_datasets_on_disk(task, generated_servo_map):
    record = _episode(task, "disk_scanner", True, roots=[task[2]])
    assert "failure" not in record, record.get("failure")
    # without it the disk is open to a policy that scans it: the result says so
    record = _episode(task, "disk_scanner", False, roots=[task[2]])
    assert record["reason"] == RAISED and "found the truth" in record["failure"]
    # through the runner: its temporary copy of the map is hidden too, and it is recorded
    m, _ = generated_servo_map
    r = run_protocol(
        Protocol("lawn:3", split="test", max_steps=3),
        m,
        1,
        f"{ATTACKS}:disk_scanner",
        workers=1,
        progress=False,
        sandbox=True,
        hide=[task[2]],
        policy_options={"roots": [task[2]]},
    )
    assert "failure" not in r["episodes_detail"][0], r["episodes_detail"][0].get("failure")
    assert r["isolation"] == {"process": True, "sandboxed": True, "sandbox": sandbox_tool()}


@pytest.mark.parametrize(
    ("name", "finds"), [("stack_walker", "run_episode:info"), ("gc_searcher", "GeodesicField")]
)
def test_in_the_evaluators_process_the_attacks_would_find_the_truth(task, name, finds):
    env, spec, _ = task
    policy = make_outside_policy(f"{ATTACKS}:{name}", env.map, np.random.default_rng(0))
    record = run_episode(env, policy, spec.seed, reset_options(env, spec, "view"))
    assert record["reason"] == RAISED and finds in record["failure"]


def test_the_maps_own_names_would_lead_to_the_recordings(task):
    env, _, data = task
    # the map the env keeps: its true names, in the dataset it was built from
    datasets = sorted(str(p) for p in Path(data).glob("generated-data*"))
    assert datasets and attacks.follow_map(env.map, datasets, budget_s=None)
