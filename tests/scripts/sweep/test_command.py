"""Evaluation sweeps (``scripts.sweep``) on the local backend: one table row per (world,
setting), the same episodes whatever the number of workers, scored as ``servo.task.evaluation``
scores them, and clear errors for bad input (Ray missing included). Cheap: the random policy, a few
12-step episodes. The Ray backend: ``test_sweep_ray.py``."""

import csv
import json
import os
import sys

import numpy as np
import pytest

from scripts.sweep.command import (
    SETTINGS,
    TIME_KEYS,
    parse_seeds,
    run_sweep,
    sweep_meta,
    write_table,
)
from servo.task.evaluation import episode_seeds

MAX_STEPS = 12
SEEDS = [0, 1]
EPISODES = 2  # per seed: 4 episodes on 2 workers, so sub-envs are reset mid-batch


@pytest.fixture(scope="session")
def cache(map_cache):
    return map_cache


@pytest.fixture(scope="session")
def hallway_map(servo_maps):
    return servo_maps["hallway"]


def _sweep(hallway_map, cache, settings, num_envs, policy="random"):
    return run_sweep(
        ["hallway"],
        SEEDS,
        settings,
        policy=policy,
        episodes_per_seed=EPISODES,
        num_envs=num_envs,
        progress=False,
        max_steps=MAX_STEPS,
        maps={"hallway": hallway_map},
        cache=cache,
    )


@pytest.fixture(scope="module")
def rows(hallway_map, cache):
    return _sweep(hallway_map, cache, ["default", "randomized"], num_envs=2)


def test_one_row_per_world_and_setting(rows, tmp_path):
    assert [(r["world"], r["setting"], r["policy"]) for r in rows] == [
        ("hallway", "default", "random"),
        ("hallway", "randomized", "random"),
    ]
    for r in rows:
        assert r["episodes"] == len(SEEDS) * EPISODES and r["num_envs"] == 2
        assert r["backend"] == "local" and r["episodes_per_min"] > 0
        detail = r["episodes_detail"]
        assert [(d["seed"], d["episode"]) for d in detail] == [(0, 0), (0, 1), (1, 0), (1, 1)]
        assert all(1 <= d["steps"] <= MAX_STEPS for d in detail)
        assert 0 <= r["success_rate"] <= 1 and 0 <= r["spl"] <= 1 and r["worker_s"] > 0
        assert r["mean_steps"] == pytest.approx(np.mean([d["steps"] for d in detail]))
        assert r["worker_s"] == pytest.approx(sum(d["wall_s"] for d in detail))
    # whole episodes ran in the workers, not in this process
    pids = {d["pid"] for r in rows for d in r["episodes_detail"]}
    assert len(pids) <= 2 and os.getpid() not in pids
    # the same starts and targets in every setting: settings are compared on the same tasks
    a, b = (r["episodes_detail"] for r in rows)
    assert [d["target_view"] for d in a] == [d["target_view"] for d in b]

    meta = sweep_meta(rows, SEEDS, EPISODES, MAX_STEPS, wall_s=1.0)
    paths = write_table(rows, tmp_path / "sweep", meta)
    table = list(csv.DictReader(paths["csv"].open()))
    assert [(t["world"], t["setting"]) for t in table] == [
        ("hallway", "default"),
        ("hallway", "randomized"),
    ]
    assert int(table[0]["episodes"]) == 4
    md = paths["md"].read_text()
    assert md.count("\n| hallway |") == 2 and "backend local, num_envs 2" in md
    assert "episodes/min on 2 workers" in md
    saved = json.loads(paths["json"].read_text())
    assert saved["meta"]["cores"] >= 1 and saved["meta"]["settings"] == ["default", "randomized"]
    assert len(saved["rows"]) == 2
    assert not list((tmp_path / "sweep").glob(".*tmp"))  # atomic writes leave nothing behind


def test_episodes_do_not_depend_on_num_envs(rows, hallway_map, cache):
    (one,) = _sweep(hallway_map, cache, ["randomized"], num_envs=1)
    assert one["num_envs"] == 1

    def strip(r):
        return [{k: v for k, v in d.items() if k not in TIME_KEYS} for d in r["episodes_detail"]]

    assert strip(one) == strip(rows[1])


def test_scored_as_servo_evaluate(rows, hallway_map):
    """A sweep episode is ``servo.task.evaluation.run_episode`` of the same reset seed and
    policy."""
    from servo.task.baseline_policies import RandomPolicy
    from servo.task.env import ServoEnv
    from servo.task.evaluation import run_episode

    got = rows[1]["episodes_detail"][3]  # randomized, seed 1, episode 1: a reset mid-batch
    seed = episode_seeds(1, EPISODES)[1]
    env = ServoEnv("hallway", hallway_map, max_steps=MAX_STEPS, **SETTINGS["randomized"])
    try:
        want = run_episode(env, RandomPolicy(np.random.default_rng(seed)), seed)
    finally:
        env.close()
    assert got["reset_seed"] == seed
    for k in (
        "success",
        "reason",
        "spl",
        "shortest_path",
        "path_length",
        "final_distance",
        "final_heading_error_deg",
        "steps",
        "collisions",
        "target_view",
    ):
        assert got[k] == pytest.approx(want[k]), k
    assert np.allclose(got["start_pose"], want["trail"][0])


@pytest.mark.parametrize(
    ("kwargs", "match"),
    [
        ({"worlds": ["moon"]}, "worlds must be"),
        ({"worlds": []}, "worlds must be"),
        ({"settings": ["foggy"]}, "settings must be"),
        ({"policy": "teleport"}, "policy must be"),
        ({"seeds": []}, "seeds must be"),
        ({"seeds": [0.5]}, "seeds must be"),
        ({"episodes_per_seed": 0}, "episodes_per_seed must be"),
        ({"num_envs": 0}, "num_envs must be"),
        ({"backend": "dask"}, "backend must be one of"),
        ({"address": "127.0.0.1:6379"}, "address is for the ray backend only"),
        ({"backend": "ray", "address": "  "}, "address must be"),
        ({"backend": "ray", "address": "localhost:port"}, "address must look like"),
    ],
)
def test_bad_input_raises(kwargs, match):
    args = {"worlds": ["hallway"], "seeds": [0], "settings": ["default"], "policy": "random"}
    args.update(kwargs)
    with pytest.raises(ValueError, match=match):
        run_sweep(**args, progress=False)


def test_parse_seeds():
    assert parse_seeds("0-3") == [0, 1, 2, 3]
    assert parse_seeds("0,2,5-6") == [0, 2, 5, 6]
    for bad in ("", "a-b", "3-1"):
        with pytest.raises(ValueError):
            parse_seeds(bad)


def test_cli_rejects_unknown_setting(capsys):
    from scripts.cli import main

    assert main(["sweep", "--world", "hallway", "--settings", "default,foggy"]) == 2
    assert "settings must be" in capsys.readouterr().err


def test_cli_writes_the_table(hallway_map, servo_dataset, cache, tmp_path, capsys):
    from scripts.cli import main

    out = tmp_path / "sweep"
    args = "sweep --world hallway --seeds 3 --settings no-odometry-noise --episodes-per-seed 1"
    args = [*args.split(), *"--policy oracle --max-steps 5 --jobs 1 --quiet".split()]
    args += ["--data", str(servo_dataset), "--maps", str(cache), "--out", str(out)]
    assert main(args) == 0
    printed = capsys.readouterr().out
    assert "| hallway | no-odometry-noise | oracle | 1 |" in printed and "num_envs 1" in printed
    assert (out / "sweep.md").read_text() in printed
    assert {p.name for p in out.iterdir()} == {"sweep.md", "sweep.csv", "sweep.json"}


def test_ray_backend_without_ray_says_how_to_install(monkeypatch, capsys):
    """``--backend ray`` where Ray is not installed: an error saying what to install, from the
    library and from the command line; ``import scripts.sweep`` itself needs no Ray."""
    monkeypatch.setitem(sys.modules, "ray", None)  # import ray now raises ImportError
    with pytest.raises(ImportError, match=r"pip install 'ray>=2.9'"):
        run_sweep(["hallway"], [0], policy="random", backend="ray", progress=False)
    from scripts.cli import main

    assert main(["sweep", "--world", "hallway", "--backend", "ray", "--quiet"]) == 2
    assert "needs Ray: pip install" in capsys.readouterr().err


PIPED = """
import json, warnings
warnings.simplefilter("always")
from scripts.sweep.command import TIME_KEYS, run_sweep
(row,) = run_sweep(["hallway"], {seeds}, ["randomized"], policy="random",
                   episodes_per_seed={episodes}, num_envs=2, progress=False,
                   max_steps={max_steps}, dataset={dataset!r}, cache={cache!r})
detail = [{{k: v for k, v in d.items() if k not in TIME_KEYS}} for d in row["episodes_detail"]]
print(json.dumps({{"num_envs": row["num_envs"], "detail": detail}}))
"""


def test_a_sweep_runs_from_a_script_piped_to_python(rows, hallway_map, servo_dataset, cache):
    """No worker process can import a main module read from stdin: the episodes run in the
    calling process, with a warning saying why, and are those the worker processes ran."""
    import subprocess
    from pathlib import Path

    root = Path(__file__).resolve().parents[3]
    script = PIPED.format(
        seeds=SEEDS,
        episodes=EPISODES,
        max_steps=MAX_STEPS,
        dataset=str(servo_dataset),
        cache=str(cache),
    )
    env = {**os.environ, "MUJOCO_GL": os.environ.get("MUJOCO_GL", "egl"), "PYTHONPATH": str(root)}
    done = subprocess.run(
        [sys.executable, "-"],
        input=script,
        text=True,
        capture_output=True,
        cwd=root,
        env=env,
        timeout=300,
    )
    if done.returncode != 0:
        pytest.fail(f"exit {done.returncode}: {done.stderr[-2000:]}")
    assert "sweeping in this process, not in 2 worker processes" in done.stderr
    assert "save the script to a file" in done.stderr
    got = json.loads(done.stdout.strip().splitlines()[-1])
    want = [{k: v for k, v in d.items() if k not in TIME_KEYS} for d in rows[1]["episodes_detail"]]
    assert got["num_envs"] == 1
    assert got["detail"] == json.loads(json.dumps(want))
