"""The release files agree: the version and date in pyproject.toml, CITATION.cff and the
CHANGELOG, and the license that pyproject declares is the file that ships."""

import re
import tomllib
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]


def _project() -> dict:
    return tomllib.loads((ROOT / "pyproject.toml").read_text())["project"]


def _cff_field(key: str) -> str:
    """A top-level scalar of CITATION.cff (the file's own keys, not its references')."""
    match = re.search(rf"^{key}:\s*\"?([^\"\n]+)\"?\s*$", (ROOT / "CITATION.cff").read_text(), re.M)
    assert match, f"CITATION.cff has no top-level {key}"
    return match.group(1)


def test_citation_and_changelog_carry_the_package_version():
    version = _project()["version"]
    assert _cff_field("version") == version
    headings = re.findall(
        r"^## \[([^\]]+)\](?: - (\S+))?$", (ROOT / "CHANGELOG.md").read_text(), re.M
    )
    assert headings[0] == ("Unreleased", ""), "the CHANGELOG opens with [Unreleased]"
    assert headings[1] == (version, _cff_field("date-released")), (
        "the newest release in the CHANGELOG is the package's version, released on "
        "CITATION.cff's date"
    )


def test_the_declared_license_ships():
    project = _project()
    assert project["license"] == "MIT" == _cff_field("license")
    for name in project["license-files"]:
        assert (ROOT / name).is_file(), f"license file {name} missing"
    assert (ROOT / "LICENSE").read_text().startswith("MIT License\n")
