"""The suite's skip list (``tests/skip_policy.py``): a skip not on it fails the run."""

import subprocess
import sys
from pathlib import Path

import pytest

from tests.skip_policy import ALLOWED_SKIPS, AllowedSkip, unlisted_skips

POLICY = Path(__file__).parent / "skip_policy.py"


def test_listed_skips_pass_and_others_are_named():
    skips = [
        ("tests/sim/readers/test_carmen.py::test_the_radish_logs", "TOPOMAP_RADISH is not set: x"),
        ("tests/mapping/test_sklearn_checks.py::test_x[y]", "SCIPY_ARRAY_API is not set: z"),
        ("tests/servo/test_a.py::test_b", "SCIPY_ARRAY_API is not set: z"),  # not in mapping
        ("tests/sim/test_env.py::test_c", "could not import 'cv2'"),
    ]
    assert unlisted_skips(skips) == skips[2:]
    assert unlisted_skips([]) == []
    only = (AllowedSkip("tests/sim/*", "could not import", "a reason"),)
    assert unlisted_skips(skips, only) == skips[:3]


def test_every_entry_says_why():
    assert len({(e.nodeid, e.message) for e in ALLOWED_SKIPS}) == len(ALLOWED_SKIPS)
    for entry in ALLOWED_SKIPS:
        assert entry.nodeid.startswith("tests/") and entry.message and len(entry.why) > 30


CONFTEST = f"""
import importlib.util
import sys

spec = importlib.util.spec_from_file_location("skip_policy", {str(POLICY)!r})
policy = sys.modules["skip_policy"] = importlib.util.module_from_spec(spec)
spec.loader.exec_module(policy)
pytest_configure = policy.pytest_configure
pytest_runtest_logreport = policy.pytest_runtest_logreport
pytest_sessionfinish = policy.pytest_sessionfinish
pytest_terminal_summary = policy.pytest_terminal_summary
"""

TESTS = """
import pytest


def test_runs():
    assert True


def test_needs_the_logs():
    pytest.skip("TOPOMAP_RADISH is not set: set it")


@pytest.mark.xfail(reason="an expected failure is no skip")
def test_xfails():
    assert False
"""


@pytest.mark.parametrize("workers", [["-n", "0"], ["-n", "2"]])
@pytest.mark.parametrize("unlisted", [False, True])
def test_a_run_fails_on_a_skip_not_on_the_list(tmp_path, workers, unlisted):
    (tmp_path / "conftest.py").write_text(CONFTEST)
    (tmp_path / "tests").mkdir()
    extra = '\n\ndef test_new_skip():\n    pytest.skip("a reason no one wrote down")\n'
    (tmp_path / "tests" / "test_some.py").write_text(TESTS + (extra if unlisted else ""))
    run = subprocess.run(
        [sys.executable, "-m", "pytest", "-p", "no:cacheprovider", "-q", *workers, "tests"],
        cwd=tmp_path,
        capture_output=True,
        text=True,
        timeout=120,
    )
    out = run.stdout
    assert ("1 passed" in out) and ("1 xfailed" in out), out
    if unlisted:
        assert run.returncode == 1, out
        assert "skips not on the list in tests/skip_policy.py" in out
        assert "tests/test_some.py::test_new_skip: a reason no one wrote down" in out
        assert "test_needs_the_logs:" not in out  # the listed skip is not named
    else:
        assert run.returncode == 0, out
        assert "2 skipped" not in out and "1 skipped" in out
