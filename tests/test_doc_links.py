"""Every documentation page the repository names exists: a docstring, help text, comment or
page that points a reader at a page or figure below ``docs/`` points at a file that is there,
so that moving or merging a page cannot leave readers at a dead end."""

from __future__ import annotations

import re
import subprocess
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
# a path below docs/ with a suffix; an anchor after it (#...) is the page's business
DOC_PATH = re.compile(r"(?<![\w/.-])docs/[\w./-]*?\.(?:md|png|jpg|json)\b")
# the tests whose tables of example strings name made-up paths
EXAMPLES = {"tests/test_doc_links.py", "tests/test_speaks_of_itself.py"}


def _tracked_text_files() -> list[Path]:
    out = subprocess.run(
        ["git", "ls-files"], cwd=ROOT, capture_output=True, text=True, check=True
    ).stdout.split()
    files = []
    for name in out:
        if name in EXAMPLES:
            continue
        path = ROOT / name
        if path.suffix in {".py", ".md", ".sh", ".toml", ".yml", ".yaml", ".cff", ".txt"}:
            files.append(path)
    return files


def test_the_pattern_finds_doc_paths():
    text = "see docs/guides/servo.md#targets, docs/img/a.png and `docs/decisions/050-x.md`."
    assert DOC_PATH.findall(text) == [
        "docs/guides/servo.md",
        "docs/img/a.png",
        "docs/decisions/050-x.md",
    ]
    assert DOC_PATH.findall("mydocs/x.md /abs/docs/y.md") == []


def test_every_named_doc_exists():
    missing = []
    for path in _tracked_text_files():
        for number, line in enumerate(path.read_text(errors="replace").splitlines(), 1):
            for found in DOC_PATH.findall(line):
                if not (ROOT / found).exists():
                    missing.append(f"{path.relative_to(ROOT)}:{number}: {found}")
    assert not missing, "pages named but absent:\n" + "\n".join(missing)


def test_every_decision_record_is_listed():
    folder = ROOT / "docs" / "decisions"
    index = (folder / "index.md").read_text()
    records = sorted(p.name for p in folder.glob("[0-9][0-9][0-9]-*.md"))
    assert records, "no decision records"
    assert [r for r in records if f"({r})" not in index] == []


def test_no_docs_page_is_over_600_lines():
    long = {
        str(p.relative_to(ROOT)): n
        for p in [*(ROOT / "docs").rglob("*.md"), ROOT / "README.md"]
        if (n := len(p.read_text().splitlines())) > 600
    }
    assert not long, f"pages over 600 lines: {long}"
