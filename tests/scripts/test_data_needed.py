"""The commands that read data, run in an empty folder: the default dataset is collected with a
line saying so, any other missing one is named with the ``topomap collect`` command that would
collect it and the option that points elsewhere."""

from pathlib import Path

import pytest

from scripts import data_needed
from scripts.cli import main
from sim.collect import CollectionSettings


@pytest.fixture
def empty_folder(tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)
    return tmp_path


def test_servo_eval_names_the_command_for_a_missing_data_folder(empty_folder, capsys):
    rc = main(["servo-eval", "--world", "lawn", "--episodes", "1", "--data", "mine"])
    err = capsys.readouterr().err
    assert rc == 2
    assert "`topomap collect --world all --out mine`" in err and "--data" in err
    assert not (empty_folder / "mine").exists()  # nothing written for a folder named wrong


def test_group_eval_names_the_command_for_a_missing_data_folder(empty_folder, capsys):
    rc = main(["group-eval", "--data", "mine", "--out", "groups"])
    assert rc == 2
    assert "`topomap collect --world all --out mine`" in capsys.readouterr().err


def test_the_default_data_folder_is_collected_with_a_line_saying_so(
    empty_folder, monkeypatch, capsys
):
    calls = []

    def fake_collect(directory, settings, progress=True):
        calls.append((str(directory), settings))
        monkeypatch.setattr(data_needed, "is_collected", lambda path: True)

    monkeypatch.setattr("sim.collect.collect_dataset", fake_collect)
    path = data_needed.ensure_dataset(Path("out/dataset"), "servo-eval", progress=False)
    assert path == "out/dataset" and calls == [("out/dataset", CollectionSettings())]
    assert "collecting the default one there" in capsys.readouterr().err
    data_needed.ensure_dataset(Path("out/dataset"), "servo-eval", progress=False)
    assert len(calls) == 1  # collected once, then read


def test_a_data_folder_that_is_not_the_default_is_never_collected(empty_folder):
    with pytest.raises(ValueError, match="point --data at a collected dataset"):
        data_needed.ensure_dataset("elsewhere/dataset", "servo-eval")
    assert not (empty_folder / "elsewhere").exists()


def test_manifold_eval_names_the_seed_and_the_condition_that_needs_it(empty_folder, capsys):
    (empty_folder / "root" / "m-data-1").mkdir(parents=True)
    (empty_folder / "root" / "m-data-1" / "meta.json").write_text("{}")
    argv = [
        "manifold-eval",
        "--root",
        "root",
        "--out",
        "o",
        "--baselines",
        "--seeds",
        "1",
        "--conditions",
        "held-out",
        "--quiet",
    ]
    assert main(argv) == 2
    err = capsys.readouterr().err
    assert "`topomap collect --world all --seed 2 --out root/m-data-2`" in err
    assert "held-out condition of seed 1" in err and "--conditions interleaved" in err


def test_manifold_eval_names_the_flags_of_a_randomized_dataset(empty_folder, capsys):
    argv = [
        "manifold-eval",
        "--root",
        "root",
        "--out",
        "o",
        "--baselines",
        "--seeds",
        "3",
        "--conditions",
        "randomized",
        "--quiet",
    ]
    assert main(argv) == 2
    err = capsys.readouterr().err
    assert "`topomap collect --world all --seed 3 --randomize --out root/m-data-r3`" in err
    assert "--conditions interleaved" not in err


def test_a_damaged_dataset_goes_to_the_reader_which_says_what_is_wrong(empty_folder):
    (empty_folder / "mine").mkdir()
    (empty_folder / "mine" / "meta.json").write_text("{not json")
    assert data_needed.ensure_dataset("mine", "servo-eval") == "mine"
