"""The servo-eval result file: its results kept as they are inside the envelope, read back by
``servo-compare`` and the results pages, and ranked by the leaderboard per episode."""

from scripts.cli import main
from scripts.leaderboard import load_results, rank, servo_result_file, write_result
from scripts.results.sources import servo_results
from servo.task import load_results as servo_load_results


def _results(wins, policy):
    episodes = [
        {"episode": i, "seed": 100 + i, "success": bool(w), "start_manifold": "m"}
        for i, w in enumerate(wins)
    ]
    return [
        dict(
            world="hallway",
            tier="anywhere",
            split="test",
            randomize=False,
            odometry_noise=True,
            max_steps=600,
            policy=policy,
            extra_field=[1, 2],
            episodes_detail=episodes,
        )
    ]


def test_the_envelope_keeps_the_results_and_every_reader_reads_them(tmp_path, capsys):
    a = _results([1, 0, 1, 0, 1, 0, 1, 0], "servo")
    b = _results([1, 1, 1, 1, 1, 1, 1, 0], "signal")
    pa = write_result(tmp_path / "a.json", servo_result_file(a, "servo", "test"))
    pb = write_result(tmp_path / "b.json", servo_result_file(b, "signal", "test"))
    assert servo_load_results(pa) == a  # existing fields kept, whatever they are
    assert servo_results(pb) == b
    (board,) = rank(load_results([tmp_path]), reference="servo").values()
    signal, servo = board["hallway/anywhere"]
    assert (signal.method, signal.mean, servo.mean) == ("signal", 7 / 8, 4 / 8)
    assert signal.paired["n"] == 8 and "3 better, 0 worse" in signal.paired["test"]
    assert main(["servo-compare", str(pa), str(pb)]) == 0
    assert "hallway" in capsys.readouterr().out


def test_settings_other_than_the_defaults_make_their_own_group():
    r = _results([1], "servo")
    r[0].update(randomize=True, max_steps=300)
    (record,) = servo_result_file(r, "servo", "dev")["records"]
    assert record["group"] == "hallway/anywhere/randomize/300 steps"


def test_an_outside_policy_is_named_by_its_spec_with_its_parameters():
    r = _results([1, 0], "examples.nearest_view_homing:make_policy")
    r[0]["policy_params"] = {"clearance": 0.6}
    method = servo_result_file(r, "examples.nearest_view_homing:make_policy", "test")["method"]
    source = method.pop("source")
    assert method == {
        "name": "nearest_view_homing",
        "params": {"clearance": 0.6},
        "spec": "examples.nearest_view_homing:make_policy",
        "sandboxed": False,
    }
    assert source["module"] == "examples.nearest_view_homing" and len(source["sha256"]) == 64
    builtin = servo_result_file(_results([1], "signal"), "signal", "test")["method"]
    assert (builtin["name"], builtin["params"]) == ("signal", {})
