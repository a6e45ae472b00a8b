"""Sweeps on Ray (``scripts.sweep.ray_backend``): the same table as the local
backend for the same seeds, whatever the number of workers; MuJoCo renders in Ray workers with the
parent's GL backend; an unreachable or non-Ray address fails at once with a clear error. Ray runs
locally with 2 CPUs and a small object store, and is shut down after. The tests that need Ray
skip where it is missing (it is in the dev extra, so the suite's skip list fails them there);
the probe of an address needs no Ray and always runs."""

import os
import socket
import threading
import time

import pytest

from scripts.sweep.command import SWEEP_KEYS, TIME_KEYS, run_sweep

MAX_STEPS = 12
SEEDS = [0, 1]
EPISODES = 2
SETTINGS = ["default", "randomized"]
HANG = 60  # s: far above the probe's 5 s; an unbounded ray.init retried for over 3 minutes


@pytest.fixture(scope="module")
def ray():
    """The ``ray`` module, or a skip where it is not installed."""
    return pytest.importorskip("ray")


@pytest.fixture(scope="module")
def hallway_map(servo_maps):
    return servo_maps["hallway"]


def _sweep(hallway_map, backend, num_envs, settings=SETTINGS):
    return run_sweep(
        ["hallway"],
        SEEDS,
        settings,
        policy="servo",
        episodes_per_seed=EPISODES,
        num_envs=num_envs,
        progress=False,
        max_steps=MAX_STEPS,
        maps={"hallway": hallway_map},
        backend=backend,
    )


def _table(rows):
    """Everything in the rows but the timings and worker ids."""
    out = []
    for r in rows:
        row = {k: v for k, v in r.items() if k not in (*TIME_KEYS, *SWEEP_KEYS, "episodes_detail")}
        row["episodes"] = [
            {k: v for k, v in d.items() if k not in TIME_KEYS} for d in r["episodes_detail"]
        ]
        out.append(row)
    return out


@pytest.fixture(scope="module")
def local_rows(ray, hallway_map):
    return _sweep(hallway_map, "local", 2)


def test_ray_starts_and_stops_its_own_local_instance(ray, hallway_map, local_rows):
    """Without an address the backend starts a 2-CPU Ray (2 workers) and shuts it down; the
    servo controller, which acts on the rendered images, drives exactly as on the local
    backend: the same table, episode by episode."""
    assert not ray.is_initialized()
    rows = _sweep(hallway_map, "ray", 2)
    assert not ray.is_initialized()
    assert [(r["backend"], r["num_envs"]) for r in rows] == [("ray", 2)] * 2
    assert _table(rows) == _table(local_rows)
    pids = {d["pid"] for r in rows for d in r["episodes_detail"]}
    assert len(pids) == 2 and os.getpid() not in pids  # both actors ran episodes


@pytest.fixture(scope="module")
def ray_session(ray):
    """A small local Ray the backend finds already running (and leaves running)."""
    ray.init(
        address="local",
        num_cpus=2,
        include_dashboard=False,
        object_store_memory=200 << 20,
        logging_level="warning",
    )
    yield ray
    ray.shutdown()


def test_one_ray_worker_gives_the_same_table(ray_session, hallway_map, local_rows):
    ray = ray_session
    rows = _sweep(hallway_map, "ray", 1, ["randomized"])
    assert ray.is_initialized()  # the caller's session is left alone
    assert rows[0]["num_envs"] == 1 and len({d["pid"] for d in rows[0]["episodes_detail"]}) == 1
    assert _table(rows) == _table(local_rows[1:])


def test_ray_workers_render_with_the_parents_gl_backend(ray_session):
    ray = ray_session

    from scripts.sweep.ray_backend import runtime_env

    @ray.remote(num_cpus=1, runtime_env={"env_vars": runtime_env(None)["env_vars"]})
    def render():
        import gymnasium as gym

        import sim  # noqa: F401

        env = gym.make("topomap/Hallway-v0")
        try:
            obs, _ = env.reset(seed=0)
        finally:
            env.close()
        return os.environ.get("MUJOCO_GL"), obs["image"]

    backend, image = ray.get(render.remote())
    assert backend == os.environ["MUJOCO_GL"]
    assert image.ndim == 3 and image.std() > 5  # a rendered scene, not a blank frame


def _free_port() -> int:
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


def test_unreachable_address_fails_at_once(ray, hallway_map):
    """Nothing listening there: a ConnectionError naming the address, before any map is built
    or any worker started."""
    address = f"127.0.0.1:{_free_port()}"
    t0 = time.monotonic()
    with pytest.raises(ConnectionError, match=f"no Ray cluster answers at address '{address}'"):
        run_sweep(
            ["hallway"],
            [0],
            policy="random",
            backend="ray",
            address=address,
            progress=False,
            maps={"hallway": hallway_map},
        )
    assert time.monotonic() - t0 < HANG


def test_an_address_that_is_not_ray_fails_at_once():
    """Something answers there, but not gRPC (a plain HTTP server): a clear error, no hang."""
    from scripts.sweep.ray_backend import probe_address

    server = socket.create_server(("127.0.0.1", 0))

    def answer():
        conn, _ = server.accept()
        with conn:
            conn.recv(64)
            conn.sendall(b"HTTP/1.1 400 Bad Request\r\n\r\n")

    thread = threading.Thread(target=answer, daemon=True)
    thread.start()
    address = f"127.0.0.1:{server.getsockname()[1]}"
    t0 = time.monotonic()
    try:
        with pytest.raises(ConnectionError, match="answers, but not as a Ray cluster"):
            probe_address(address)
    finally:
        server.close()
    assert time.monotonic() - t0 < HANG


def test_cli_unreachable_address(ray, capsys):
    from scripts.cli import main

    address = f"127.0.0.1:{_free_port()}"
    assert (
        main(["sweep", "--world", "hallway", "--backend", "ray", "--address", address, "--quiet"])
        == 2
    )
    err = capsys.readouterr().err
    assert err.startswith("topomap sweep: no Ray cluster answers") and "ray start --head" in err


def test_held_out_cells_run_on_ray_actors(ray_session, tmp_path):
    """The held-out evaluation's cells through the Ray backend's actors (``start_runner``):
    a cached cell comes back as it was stored, from an actor's process."""
    from common.fileio import write_json
    from scripts.heldout.cells import CELL_VERSION, MANIFOLD_VERSION, cell_path
    from scripts.heldout.evaluate import CellRunner
    from scripts.sweep.backends import open_backend

    cell = {
        "version": CELL_VERSION,
        "world": "lawn:11001",
        "family": "lawn",
        "seed": 0,
        "frames": 150,
        "tasks": {
            "manifold": {"version": MANIFOLD_VERSION, "rows": []},
            "servo": {"episodes": 3, "indices": [0, 2, 1]},
        },
    }
    path = cell_path(tmp_path, "lawn:11001", 0, 150)
    path.parent.mkdir(parents=True)
    write_json(path, cell)
    with open_backend("ray", 1) as workers:
        workers.start_runner(CellRunner, tmp_path, tmp_path / "data", 150, ("manifold", "servo"))
        [(i, got)] = list(workers.run([("lawn:11001", 0, 3)]))
    assert i == 0 and got == cell
