"""Worker processes that cannot start: a main module read from standard input. The library
then runs in the calling process, with a warning saying why."""

import os
import subprocess
import sys
import types
from pathlib import Path

import pytest

from common.cores import spawn_problem

ROOT = Path(__file__).resolve().parents[2]


def _main(monkeypatch, **attributes):
    main = types.ModuleType("__main__")
    for name, value in attributes.items():
        setattr(main, name, value)
    monkeypatch.setitem(sys.modules, "__main__", main)


def test_a_main_module_read_from_stdin_cannot_be_spawned(monkeypatch, tmp_path):
    _main(monkeypatch, __file__="<stdin>", __spec__=None)
    assert "read from '<stdin>', not from a file" in spawn_problem()
    script = tmp_path / "script.py"
    script.write_text("")
    _main(monkeypatch, __file__=str(script), __spec__=None)
    assert spawn_problem() is None
    _main(monkeypatch, __spec__=None)  # python -c, the interactive prompt: no file to import
    assert spawn_problem() is None
    _main(monkeypatch, __file__="<stdin>", __spec__=types.SimpleNamespace(name="pkg.tool"))
    assert spawn_problem() is None  # python -m: imported by name


SCRIPT = """
import warnings
warnings.simplefilter("always")
import sim
from sim.camera import CameraConfig
from sim.collect import CollectionSettings, collect_dataset
from sim.dataset import load_dataset
settings = CollectionSettings(worlds=("lawn",), frames=3, camera=CameraConfig(width=16, height=12))
path = collect_dataset({out!r}, settings, jobs=2, progress=False)
print("sequences", len(load_dataset(path).sequences))
"""


def test_the_library_runs_from_a_script_piped_to_python(tmp_path):
    env = {**os.environ, "MUJOCO_GL": os.environ.get("MUJOCO_GL", "egl"), "PYTHONPATH": str(ROOT)}
    done = subprocess.run(
        [sys.executable, "-"],
        input=SCRIPT.format(out=str(tmp_path / "data")),
        text=True,
        capture_output=True,
        cwd=ROOT,
        env=env,
        timeout=300,
    )
    if done.returncode != 0:
        pytest.fail(f"exit {done.returncode}: {done.stderr[-2000:]}")
    assert "sequences 3" in done.stdout
    assert "collecting in this process, not in 2 workers" in done.stderr


def _daemon_problem(queue):
    from common.cores import spawn_problem

    queue.put(spawn_problem())


def test_a_daemonic_worker_cannot_start_children():
    import multiprocessing

    ctx = multiprocessing.get_context("spawn")
    queue = ctx.Queue()
    worker = ctx.Process(target=_daemon_problem, args=(queue,), daemon=True)
    worker.start()
    problem = queue.get(timeout=60)
    worker.join(timeout=60)
    assert "daemonic worker" in problem
