"""README.md's Python examples run as written, one after another in one namespace (as in a
REPL), in a fresh working directory and a fresh data home."""

import re
from pathlib import Path

import sim  # noqa: F401  (headless GL before anything imports mujoco)

README = Path(__file__).resolve().parents[1] / "README.md"
BLOCK = re.compile(r"^```python\n(.*?)^```", re.M | re.S)


def blocks() -> list[str]:
    return BLOCK.findall(README.read_text())


def test_the_readme_has_python_examples():
    assert blocks(), "README.md has no ```python block"


def test_the_readme_examples_run(tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)
    (tmp_path / "home").mkdir()
    monkeypatch.setenv("TOPOMAP_HOME", str(tmp_path / "home"))
    namespace = {"__name__": "readme"}
    for number, code in enumerate(blocks(), 1):
        # the block's name as the file name: a traceback points at the README's block and line
        exec(compile(code, f"README.md python block {number}", "exec"), namespace)
    # what the examples write lands in the working directory and the data home
    assert (tmp_path / "data" / "mine" / "meta.json").is_file()
    assert any((tmp_path / "home" / "servo-maps").iterdir())
