"""What is needed to reproduce a report: package versions, the machine, the git commit."""

from __future__ import annotations

import os
import platform
import subprocess
from pathlib import Path

__all__ = ["REPO_ROOT", "VERSION_PACKAGES", "git_commit", "machine", "versions"]

VERSION_PACKAGES = ("mujoco", "gymnasium", "numpy", "scipy", "opencv-python-headless", "tqdm")
# The repository's root: scripts/report/provenance.py -> three levels up.
REPO_ROOT = Path(__file__).resolve().parents[2]


def versions() -> dict[str, str]:
    """Return the versions of Python and of `VERSION_PACKAGES` ("not installed" if missing).

    Returns
    -------
    dict of str to str
        The version per name.
    """
    from importlib.metadata import PackageNotFoundError, version

    out = {"python": platform.python_version()}
    for name in VERSION_PACKAGES:
        try:
            out[name] = version(name)
        except PackageNotFoundError:
            out[name] = "not installed"
    return out


def machine() -> dict[str, str]:
    """Describe the machine: CPU model, core count, platform and ``MUJOCO_GL``.

    Returns
    -------
    dict of str to str
        The entries, by label.
    """
    cpu = platform.processor() or platform.machine()
    try:
        for line in Path("/proc/cpuinfo").read_text().splitlines():
            if line.startswith("model name"):
                cpu = line.split(":", 1)[1].strip()
                break
    except OSError:
        pass
    return {
        "cpu": cpu,
        "cores (os.cpu_count)": str(os.cpu_count()),
        "platform": platform.platform(),
        "MUJOCO_GL": os.environ.get("MUJOCO_GL", "unset"),
    }


def git_commit(repo: Path | None = None) -> str | None:
    """Read the checked-out commit, read-only; None outside a git checkout.

    Parameters
    ----------
    repo : Path or None, default None
        The checkout; None: the repository's root, `REPO_ROOT`.

    Returns
    -------
    str or None
        The commit's hash.
    """
    repo = repo or REPO_ROOT
    try:
        out = subprocess.run(
            ["git", "rev-parse", "HEAD"], cwd=repo, capture_output=True, text=True, timeout=10
        )
    except (OSError, subprocess.SubprocessError):
        return None
    return out.stdout.strip() or None if out.returncode == 0 else None
