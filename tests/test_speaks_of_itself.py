"""The repository speaks only of itself: no tracked file, and no tracked file's name, refers to
how the work on it was organised (numbered sessions, rounds, issues, items, sprints,
milestones or work periods, or ordinals such as "the fourth round").

Docs and code say what the software does, how to use it, what it measured and why; a label
for when something was done means nothing to a reader and goes stale with the next change.
The scan reads every file ``git ls-files`` lists (binary files skipped); outside a git
checkout it walks the tree, skipping virtual environments, outputs and caches.
"""

from __future__ import annotations

import os
import re
import subprocess
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
SELF = Path(__file__).resolve().relative_to(ROOT).as_posix()  # its table must name the labels
SKIP_DIRS = {
    ".git",
    ".venv",
    "venv",
    "out",
    "site",
    "__pycache__",
    ".pytest_cache",
    ".ruff_cache",
    "build",
    "dist",
}

_WORDS = r"(?:sessions?|rounds?|issues?|items?|sprints?|milestones?|work[ _-]?periods?)"
_UNITS = r"(?:sessions?|rounds?|sprints?|milestones?|work[ _-]?periods?)"
_ORDINAL = (
    r"(?:first|second|third|fourth|fifth|sixth|seventh|eighth|ninth|tenth|eleventh|twelfth"
    r"|(?:thir|four|fif|six|seven|eigh|nine)teenth|(?:twentie|thirtie)th"
    r"|(?:twenty|thirty)[ -]?(?:first|second|third|fourth|fifth|sixth|seventh|eighth|ninth)"
    r"|\d+(?:st|nd|rd|th))"
)
# Between a label and its number: nothing, a space, '#', '-' or '_' ("round16", "issue #14",
# "signal-round16"), or a line break inside a comment or docstring ("(session\n    # 20)").
_GAP = r"(?:[ \t#_-]{0,3}|[ \t]*\n[ \t#*>/\"'-]*)"
LABEL = re.compile(
    # a letter before the word makes it another word: "around 3", "background 2"
    rf"(?<![a-z]){_WORDS}{_GAP}\d"
    rf"|\b{_ORDINAL}[ \t-]+{_UNITS}\b(?!-(?:off|trip|robin))"
    r"|\b(?:a later|an earlier|the previous|the next|the last|this|that)"
    r" (?:session|work period)s?\b"
    r"|\bwork[ _-]periods?\b",
    re.IGNORECASE,
)


def labels(text: str) -> list[tuple[int, str]]:
    """Every reference to how the work was organised in ``text``: (line number, that line)."""
    lines = text.splitlines()
    found = []
    for match in LABEL.finditer(text):
        line = text.count("\n", 0, match.start())
        if not found or found[-1][0] != line + 1:
            found.append((line + 1, lines[line].strip()))
    return found


def tracked_files() -> list[str]:
    """The files git tracks, relative to the root; outside a checkout, every file in the tree
    but those of ``SKIP_DIRS`` and packaging metadata."""
    try:
        listed = subprocess.run(
            ["git", "-C", str(ROOT), "ls-files", "-z"], capture_output=True, check=True, timeout=60
        ).stdout.decode()
    except (OSError, subprocess.SubprocessError):
        listed = ""
    if listed:
        return [name for name in listed.split("\0") if name and (ROOT / name).is_file()]
    names = []
    for folder, dirs, files in os.walk(ROOT):
        dirs[:] = [d for d in dirs if d not in SKIP_DIRS and not d.endswith(".egg-info")]
        names += [(Path(folder) / f).relative_to(ROOT).as_posix() for f in files]
    return sorted(names)


def text_of(name: str) -> str | None:
    """The file's text, or None for a binary file (a NUL byte, or not UTF-8)."""
    data = (ROOT / name).read_bytes()
    if b"\0" in data[:8192]:
        return None
    try:
        return data.decode("utf-8")
    except UnicodeDecodeError:
        return None


@pytest.mark.parametrize(
    "text",
    [
        "the code before session 18",
        "issue 14's speed targets",
        "(issue 12, item 2)",
        "(round 10)",
        "Round 7 against round 8",
        "Rounds 13-15 named",
        "see issue #14",
        "issue-14",
        "session#3",
        "docs/results/signal-round16/a.json",
        "servo-round3",
        "test_cli_on_round10",
        "sprint 4",
        "Milestone 2",
        "work period 3",
        "the work-period",
        "the fourth round",
        "a second session",
        "The Third Round",
        "the 18th session",
        "a later session",
        "twenty-first round",
        "(session\n    # 20)",
        '"ties decided by the\n    code before session\n    18"',
        "items 2 and 3",
    ],
)
def test_the_pattern_finds_work_period_labels(text):
    assert labels(text), text


@pytest.mark.parametrize(
    "text",
    [
        "round to 3 decimals",
        "rounding to 2 places",
        "np.round(x, 2)",
        "round(x, 3)",
        "the issue is that",
        "issues with the solver",
        "https://github.com/foo/bar/issues/123",
        "see foo/bar#123",
        "around 3 m",
        "the ground 2 m away",
        "background 4",
        "round-off of 1e-13",
        "round-trips 3 times",
        "at most 3 rounds",
        "lateral_rounds = 2",
        "a new round of the sweep",
        "each round",
        "the first round-off",
        "items()",
        "spec['items'][0]",
        'scope="session"',
        "collected once per session",
        "the caller's Ray session",
        "a period of 32 pixels",
        "eq. 13",
        "Figure 7",
        "Section II-G",
        "turned round, 2 m on",
    ],
)
def test_the_pattern_leaves_ordinary_words_alone(text):
    assert not labels(text), labels(text)


def test_the_fallback_walk_finds_what_git_tracks(monkeypatch):
    tracked = set(tracked_files())
    monkeypatch.setattr(subprocess, "run", _no_git)
    walked = set(tracked_files())
    assert SELF in walked and "pyproject.toml" in walked
    assert not any(name.startswith((".git/", ".venv/")) for name in walked)
    assert tracked <= walked


def _no_git(*args, **kwargs):
    raise FileNotFoundError("git")


def test_no_file_refers_to_how_the_work_was_organised():
    hits = []
    for name in tracked_files():
        if labels(name):
            hits.append(f"{name}: (its name)")
        if name == SELF:
            continue
        text = text_of(name)
        if text is not None:
            hits += [f"{name}:{line}: {content}" for line, content in labels(text)]
    if hits:
        pytest.fail(
            f"{len(hits)} references to how the work was organised:\n" + "\n".join(hits),
            pytrace=False,
        )
