"""The data home: argument, then TOPOMAP_HOME, then the per-user cache; never the working
directory. A named home must exist; the default dataset is collected once and never replaced."""

import json

import pytest

from sim import datahome
from sim.datahome import DataHomeError, data_home, default_dataset, maps_dir


@pytest.fixture(autouse=True)
def _no_home_env(monkeypatch, tmp_path):
    monkeypatch.delenv(datahome.ENV_VAR, raising=False)
    monkeypatch.setenv("XDG_CACHE_HOME", str(tmp_path / "xdg"))
    monkeypatch.chdir(tmp_path)


def test_order_argument_then_variable_then_user_cache(tmp_path, monkeypatch):
    assert data_home() == (tmp_path / "xdg" / "topomap").resolve()
    assert data_home().is_dir()  # the per-user cache is created on first use
    (tmp_path / "env").mkdir()
    monkeypatch.setenv(datahome.ENV_VAR, str(tmp_path / "env"))
    assert data_home() == (tmp_path / "env").resolve()
    (tmp_path / "arg").mkdir()
    assert data_home(tmp_path / "arg") == (tmp_path / "arg").resolve()


def test_a_relative_home_is_made_absolute(tmp_path):
    (tmp_path / "rel").mkdir()
    assert data_home("rel") == (tmp_path / "rel").resolve()


def test_without_xdg_the_cache_is_under_the_user_home(tmp_path, monkeypatch):
    monkeypatch.delenv("XDG_CACHE_HOME")
    monkeypatch.setenv("HOME", str(tmp_path / "user"))
    assert datahome.user_cache_dir() == tmp_path / "user" / ".cache" / "topomap"


def test_a_named_home_that_does_not_exist_is_an_error(tmp_path, monkeypatch):
    with pytest.raises(DataHomeError, match="home names the data home .*does not exist"):
        data_home(tmp_path / "nope")
    monkeypatch.setenv(datahome.ENV_VAR, str(tmp_path / "nope"))
    with pytest.raises(DataHomeError, match="TOPOMAP_HOME variable names .*does not exist"):
        data_home()
    assert not (tmp_path / "nope").exists()
    (tmp_path / "file").write_text("x")
    with pytest.raises(DataHomeError, match="not a folder"):
        data_home(tmp_path / "file")


def test_maps_dir_is_inside_the_home(tmp_path):
    (tmp_path / "h").mkdir()
    assert maps_dir(tmp_path / "h") == (tmp_path / "h" / datahome.MAPS_DIR).resolve()
    (tmp_path / "h2").mkdir()
    (tmp_path / "h2" / datahome.MAPS_DIR).write_text("x")
    with pytest.raises(DataHomeError, match="is a file"):
        maps_dir(tmp_path / "h2")


def test_default_dataset_is_collected_once_and_reused(tmp_path, monkeypatch):
    calls = []

    def fake_collect(directory, settings, progress=True, **kw):
        calls.append((directory, progress))
        directory.mkdir(parents=True, exist_ok=True)
        meta = {"format": "topomap-dataset", "schema_version": 1, "complete": True, "sequences": {}}
        (directory / "meta.json").write_text(json.dumps(meta))
        return directory

    monkeypatch.setattr("sim.collect.collect_dataset", fake_collect)
    (tmp_path / "h").mkdir()
    path = default_dataset(tmp_path / "h", progress=False)
    assert path == (tmp_path / "h" / datahome.DATASET_DIR).resolve()
    assert calls == [(path, False)]
    assert default_dataset(tmp_path / "h") == path
    assert len(calls) == 1  # reused, not collected again


def test_a_damaged_default_dataset_is_reported_not_replaced(tmp_path, monkeypatch):
    from sim.dataset import DatasetError

    monkeypatch.setattr("sim.collect.collect_dataset", pytest.fail)
    home = tmp_path / "h"
    (home / datahome.DATASET_DIR).mkdir(parents=True)
    (home / datahome.DATASET_DIR / "meta.json").write_text("{broken")
    with pytest.raises(DatasetError, match="not valid JSON"):
        default_dataset(home)
    assert (home / datahome.DATASET_DIR / "meta.json").read_text() == "{broken"


def test_servo_entry_points_never_read_the_working_directory(tmp_path, monkeypatch):
    """``evaluate`` and ``load_or_build`` with no paths go to the data home, wherever they run."""
    from servo.maps import build as map_store
    from servo.task.evaluation import evaluate

    seen = []

    def fake_default(home, progress=True):
        seen.append(home)
        pytest.fail("stop")

    monkeypatch.setattr(map_store.datahome, "default_dataset", fake_default)
    (tmp_path / "h").mkdir()
    monkeypatch.setenv(datahome.ENV_VAR, str(tmp_path / "h"))
    with pytest.raises(pytest.fail.Exception):
        evaluate("hallway", episodes=1, seed=0, progress=False)
    with pytest.raises(ValueError, match="world must be .hallway. or .lawn..*FAMILY:SEED"):
        evaluate("mars", episodes=1, seed=0)
    assert seen == [None]
    assert not (tmp_path / "out").exists()


def test_radish_log_is_read_from_the_variable_only(tmp_path, monkeypatch):
    monkeypatch.delenv(datahome.RADISH_VAR, raising=False)
    with pytest.raises(DataHomeError, match="TOPOMAP_RADISH is not set"):
        datahome.radish_log("aces-corrected.log.gz")
    monkeypatch.setenv(datahome.RADISH_VAR, str(tmp_path / "logs"))
    with pytest.raises(DataHomeError, match="TOPOMAP_RADISH=.* holds no aces-corrected"):
        datahome.radish_log("aces-corrected.log.gz")
    (tmp_path / "logs").mkdir()
    (tmp_path / "logs" / "aces-corrected.log.gz").write_bytes(b"")
    assert (
        datahome.radish_log("aces-corrected.log.gz")
        == (tmp_path / "logs" / "aces-corrected.log.gz").resolve()
    )
    with pytest.raises(DataHomeError, match="holds no csail-corrected"):
        datahome.radish_log("csail-corrected.log.gz")


def test_a_folder_lock_makes_the_second_holder_wait_saying_so(tmp_path, capsys):
    import threading
    import time

    from sim.datahome import folder_lock

    order = []

    def second():
        with folder_lock(tmp_path, "the lawn servo map"):
            order.append("second")

    with folder_lock(tmp_path, "the lawn servo map"):
        thread = threading.Thread(target=second)
        thread.start()
        time.sleep(0.5)
        order.append("first")
    thread.join(timeout=10)
    assert order == ["first", "second"]
    assert "waits for another process to finish the lawn servo map" in capsys.readouterr().err
    assert list(tmp_path.iterdir()) == []  # the folder itself is locked: no file is left
