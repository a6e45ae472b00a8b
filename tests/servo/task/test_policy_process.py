"""A policy in its own process: the plain-array messages, the map it is given, what a
misbehaving policy process does to its episode (and not to the run), and our controllers on
the same path."""

import json
import pickle
import time
from pathlib import Path

import numpy as np
import pytest

from servo.task import wire
from servo.task.guard import DIED, GARBAGE, INVALID_ACTION, RAISED, TOO_SLOW, PolicyFailure
from servo.task.interface import PolicyLoadError, Target, sensed_map
from servo.task.protocol import Protocol, run_protocol
from servo.task.remote import RemotePolicy

MISBEHAVING = "tests.servo.task.misbehaving:make"


def test_a_message_round_trips_as_plain_arrays():
    arrays = {
        "image": np.arange(24, dtype=np.uint8).reshape(2, 4, 3),
        "a": np.array([0.5, -1.0]),
        "ok": np.array([True, False]),
        "i": np.arange(3, dtype=">i8"),
    }
    kind, values, got = wire.decode(wire.encode("act", {"view": 3}, arrays), 1 << 20)
    assert kind == "act" and values == {"view": 3}
    for name, a in arrays.items():
        np.testing.assert_array_equal(got[name], a)
        assert not got[name].flags.writeable
    assert got["i"].dtype == np.dtype("<i8")


def _raw(arrays) -> bytes:
    header = json.dumps({"kind": "act", "values": {}, "arrays": arrays}).encode()
    return wire.MAGIC + len(header).to_bytes(4, "little") + header


@pytest.mark.parametrize(
    ("data", "says"),
    [
        (pickle.dumps({"action": [0.1, 0.2]}), "no TMW1 message"),
        (wire.MAGIC + b"\xff\xff\xff\x00{}", "does not fit"),
        (wire.MAGIC + (5).to_bytes(4, "little") + b"nope!", "not JSON"),
        (wire.MAGIC + (2).to_bytes(4, "little") + b"[]", "exactly the keys"),
        (wire.encode("act", {}, {"a": np.zeros(2)})[:-1], "runs past"),
        (wire.encode("act", {}, {"a": np.zeros(2)}) + b"x", "after the last array"),
        (_raw([["a", "|O", [1]]]), "dtype '|O' is not one of"),
        (_raw([["a", "<f8", [-1]]]), "shape must be"),
        (_raw([["a", "<f8", [1 << 30, 1 << 30]]]), "runs past"),
        (_raw([["a", "<f8", [1]], ["a", "<f8", [0]]]) + bytes(8), "given twice"),
    ],
)
def test_garbage_is_refused_saying_why(data, says):
    with pytest.raises(wire.WireError, match=says):
        wire.decode(data, 1 << 20)


def test_a_message_larger_than_allowed_is_refused():
    with pytest.raises(wire.WireError, match="more than the 10 allowed"):
        wire.decode(wire.encode("act"), 10)
    with pytest.raises(wire.WireError, match="dtype object"):
        wire.encode("act", {}, {"a": np.array([None])})


def test_the_map_a_policy_is_given_has_no_key_to_the_disk(generated_servo_map):
    m, cache = generated_servo_map
    s = sensed_map(m)
    assert s.sequence_names == [f"recording-{i}" for i in range(len(m.sequence_names))]
    assert not set(s.sequence_names) & set(m.sequence_names)
    for i in np.unique(m.sequence):  # each view's place in its recording, in its order
        at = m.sequence == i
        np.testing.assert_array_equal(s.frame[at], np.argsort(np.argsort(m.frame[at])))
    assert s.key != m.key and not list(Path(cache).glob(f"*{s.key}*"))
    assert s.world_digest is None and s.manifold_names == ()


@pytest.fixture(scope="module")
def remote(generated_servo_map):
    policy = RemotePolicy(MISBEHAVING, generated_servo_map[0])
    policy.limit_s = 3.0
    yield policy
    policy.close()


def _observation(m):
    return {
        "image": m.images[1],
        "scan": m.scans[1],
        "odometry": np.zeros(3),
        "target_image": m.images[0],
    }


@pytest.mark.parametrize(
    ("mode", "reason", "says"),
    [
        ("die", DIED, "exit status 3"),
        ("hang", TOO_SLOW, "no answer within 3 s"),
        ("garbage", INVALID_ACTION, "not numbers: {'v': 'fast'}"),
        ("pickle", GARBAGE, "no TMW1 message"),
        ("raise", RAISED, "RuntimeError: lost"),
    ],
)
def test_a_misbehaving_policy_process_fails_with_the_reason(
    remote, generated_servo_map, mode, reason, says
):
    from tests.servo.task.misbehaving import MODES

    m, _ = generated_servo_map
    remote.reset(Target(MODES.index(mode), m.images[0]))  # a fresh process if the last died
    t0 = time.perf_counter()
    with pytest.raises(PolicyFailure) as caught:
        remote.act(_observation(m))
    assert time.perf_counter() - t0 < 20
    assert caught.value.reason == reason and says in caught.value.detail
    assert not Path("/tmp/topomap-pwned").exists()  # nothing it sent was unpickled


def test_printing_to_stdout_does_not_disturb_the_answers(remote, generated_servo_map):
    from tests.servo.task.misbehaving import MODES

    m, _ = generated_servo_map
    remote.reset(Target(MODES.index("print"), m.images[0]))
    np.testing.assert_allclose(remote.act(_observation(m)), [0.2, 0.1])


def test_a_factory_that_fails_in_its_process_is_named(generated_servo_map):
    m, _ = generated_servo_map
    with pytest.raises(PolicyLoadError, match="does not import"):
        RemotePolicy("no_such_package.policy:make", m)


def test_the_run_goes_on_past_dead_policy_processes(generated_servo_map):
    m, _ = generated_servo_map
    protocol = Protocol("lawn:3", split="dev", max_steps=3)
    r = run_protocol(
        protocol,
        m,
        2,
        MISBEHAVING,
        workers=1,
        progress=False,
        sandbox=False,
        policy_options={"how": "die"},
    )
    assert r["reasons"] == {DIED: 2} and r["episodes"] == 2
    assert r["isolation"] == {"process": True, "sandboxed": False, "sandbox": None}
    with pytest.raises(ValueError, match="isolate=False is refused"):
        run_protocol(protocol, m, 1, MISBEHAVING, workers=1, progress=False, isolate=False)


def test_our_controller_runs_the_same_in_its_own_process(generated_servo_map):
    m, _ = generated_servo_map
    protocol = Protocol("lawn:3", split="dev", max_steps=8)
    here = run_protocol(protocol, m, 2, "random", workers=1, progress=False)
    there = run_protocol(
        protocol, m, 2, "random", workers=1, progress=False, isolate=True, sandbox=False
    )
    assert here["isolation"]["process"] is False and there["isolation"]["process"] is True
    keys = ("steps", "reason", "path_length", "final_distance", "collisions", "success")
    assert [{k: e[k] for k in keys} for e in here["episodes_detail"]] == [
        {k: e[k] for k in keys} for e in there["episodes_detail"]
    ]


def test_a_hidden_folder_that_holds_the_code_hides_everything_else(tmp_path, monkeypatch):
    from servo.task.remote import outermost

    for d in ("repo/src", "other-run/maps", "data"):
        (tmp_path / d).mkdir(parents=True)
    monkeypatch.chdir(tmp_path / "repo")  # a clone in the temporary folder
    hidden = outermost([tmp_path, tmp_path / "data"])
    assert hidden == sorted(str((tmp_path / d).resolve()) for d in ("data", "other-run"))
