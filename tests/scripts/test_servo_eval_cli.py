"""``topomap servo-eval --out``: the results file says which settings made it."""

import pytest

from scripts.cli import build_parser
from scripts.servo_commands import servo_eval_name


def _name(*argv: str) -> str:
    return servo_eval_name(build_parser().parse_args(["servo-eval", *argv]))


def test_every_setting_that_changes_the_episodes_is_in_the_file_name():
    base = _name("--world", "hallway", "--tier", "anywhere", "--split", "test")
    assert base == "servo-eval-hallway-anywhere-test-servo-100ep.json"
    others = {
        _name("--world", "lawn", "--tier", "anywhere", "--split", "test"),
        _name("--world", "hallway", "--tier", "anywhere", "--split", "test", "--randomize"),
        _name("--world", "hallway", "--tier", "anywhere", "--split", "test", "--no-odometry-noise"),
        _name("--world", "hallway", "--tier", "anywhere", "--split", "test", "--episodes", "20"),
        _name("--world", "hallway", "--tier", "anywhere", "--split", "test", "--max-steps", "900"),
        _name("--world", "hallway", "--tier", "anywhere", "--split", "test", "--policy", "signal"),
        _name("--world", "hallway", "--tier", "view", "--split", "test"),
        _name("--world", "hallway", "--tier", "anywhere", "--split", "dev"),
    }
    assert base not in others and len(others) == 8
    assert "randomize" in _name("--randomize") and "900steps" in _name("--max-steps", "900")


def _servo_eval(tmp_path, out: str) -> list[str]:
    # --data names no dataset: the run must stop at --out, before it reads any data
    return [
        "servo-eval",
        "--world",
        "hallway",
        "--episodes",
        "1",
        "--policy",
        "random",
        "--data",
        str(tmp_path / "no-dataset"),
        "--maps",
        str(tmp_path / "maps"),
        "--out",
        out,
    ]


def test_a_bad_out_is_reported_before_any_episode(tmp_path, capsys, monkeypatch):
    """An --out that is a file, lies under a file or cannot be created: one line, exit 2, and
    nothing run (it was a traceback from mkdir after every episode)."""
    import servo.task.protocol
    from scripts.cli import main

    monkeypatch.setattr(servo.task.protocol, "run_protocol", pytest.fail)
    (tmp_path / "afile").write_text("x")
    for out, why in (
        (tmp_path / "afile", "must be a folder, got the file"),
        (tmp_path / "afile" / "sub", "Not a directory"),
    ):
        assert main(_servo_eval(tmp_path, str(out))) == 2
        err = capsys.readouterr().err
        assert err.startswith("topomap servo-eval: --out must be a folder") and why in err
        assert len(err.strip().splitlines()) == 1
    assert (tmp_path / "afile").read_text() == "x"
    assert not (tmp_path / "maps").exists()


@pytest.mark.parametrize(
    "argv",
    [
        ["group-eval", "--data", "nowhere"],
        ["reproduce", "--data", "nowhere"],
        ["preview", "--data", "nowhere"],
        ["worlds", "--world", "lawn"],
        ["collect", "--world", "lawn"],
    ],
)
def test_other_commands_check_out_first(tmp_path, capsys, argv):
    (tmp_path / "afile").write_text("x")
    from scripts.cli import main

    assert main([*argv, "--out", str(tmp_path / "afile" / "sub")]) == 2
    err = capsys.readouterr().err
    assert f"topomap {argv[0]}: --out must be a folder" in err and "Not a directory" in err


def test_main_reports_an_os_error_in_one_line(tmp_path, capsys, monkeypatch):
    """What a command cannot read or write (here a preview's folder) is a message, not a
    traceback."""
    import scripts.cli as cli

    def fail(args):
        raise PermissionError(13, "Permission denied", str(tmp_path / "x.png"))

    monkeypatch.setattr(cli, "cmd_preview", fail)
    assert cli.main(["preview", "--data", "d", "--out", str(tmp_path)]) == 1
    err = capsys.readouterr().err
    assert err == f"topomap preview: [Errno 13] Permission denied: '{tmp_path / 'x.png'}'\n"


def test_the_sandbox_option_is_parsed_and_a_missing_sandbox_refused(tmp_path, capsys, monkeypatch):
    import servo.task
    from scripts.cli import main
    from servo.task import remote

    assert build_parser().parse_args(["servo-eval"]).sandbox == "auto"
    with pytest.raises(SystemExit):
        build_parser().parse_args(["servo-eval", "--sandbox", "maybe"])
    monkeypatch.setattr(remote, "sandbox_tool", lambda: None)
    monkeypatch.setattr(servo.task, "sandbox_tool", lambda: None, raising=False)
    argv = _servo_eval(tmp_path, str(tmp_path / "o"))
    argv[argv.index("random")] = "examples.my_policy:make_policy"
    assert main([*argv, "--sandbox", "on"]) == 2
    assert "--sandbox on, but neither bwrap nor unshare" in capsys.readouterr().err
