"""The pre-commit hooks run the checks of the test command (``scripts/test.sh``), so that a
commit they let through is not refused by the suite's own lint and layout check."""

from pathlib import Path

import yaml

ROOT = Path(__file__).resolve().parents[1]


def test_the_pre_commit_hooks_are_the_test_commands_checks():
    config = yaml.safe_load((ROOT / ".pre-commit-config.yaml").read_text())
    hooks = [h for repo in config["repos"] for h in repo["hooks"]]
    assert all(repo["repo"] == "local" for repo in config["repos"])  # nothing fetched
    script = (ROOT / "scripts" / "test.sh").read_text()
    entries = {h["entry"].replace(" --force-exclude", "") for h in hooks}
    assert entries == {"ruff check", "ruff format --check"}
    for entry in entries:
        assert f".venv/bin/{entry} ." in script, entry
