"""``topomap servo-eval --out``: the results file says which settings made it."""

from scripts.cli import build_parser, servo_eval_name


def _name(*argv: str) -> str:
    return servo_eval_name(build_parser().parse_args(["servo-eval", *argv]))


def test_every_setting_that_changes_the_episodes_is_in_the_file_name():
    base = _name("--world", "hallway", "--tier", "anywhere", "--split", "test")
    assert base == "servo-eval-hallway-anywhere-test-servo-100ep.json"
    others = {
        _name("--world", "lawn", "--tier", "anywhere", "--split", "test"),
        _name("--world", "hallway", "--tier", "anywhere", "--split", "test", "--randomize"),
        _name("--world", "hallway", "--tier", "anywhere", "--split", "test",
              "--no-odometry-noise"),
        _name("--world", "hallway", "--tier", "anywhere", "--split", "test", "--episodes", "20"),
        _name("--world", "hallway", "--tier", "anywhere", "--split", "test", "--max-steps", "900"),
        _name("--world", "hallway", "--tier", "anywhere", "--split", "test", "--policy", "signal"),
        _name("--world", "hallway", "--tier", "view", "--split", "test"),
        _name("--world", "hallway", "--tier", "anywhere", "--split", "dev"),
    }  # fmt: skip
    assert base not in others and len(others) == 8
    assert "randomize" in _name("--randomize") and "900steps" in _name("--max-steps", "900")
