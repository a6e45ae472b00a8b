"""The docs site as a reader opens it: built once (``mkdocs build --strict``, into a temp dir),
opened at its ``index.html``, every internal link followed to a file of the site (and to its
anchor), and no Sphinx role (``:func:`` and the like) left unrendered on a page."""

from __future__ import annotations

import importlib.util
import re
import subprocess
import sys
from html.parser import HTMLParser
from pathlib import Path
from urllib.parse import unquote, urlsplit

import pytest

ROOT = Path(__file__).resolve().parents[1]
# a role as the page shows it: its backticks rendered as <code>, or left as they were
ROLE = re.compile(r":(?:func|meth|class|mod|data|attr|obj|exc|const|ref|py:\w+):(?:`|<code>)")


class _Page(HTMLParser):
    """The hrefs and srcs of a page, and the ids it defines."""

    def __init__(self):
        super().__init__()
        self.links: list[str] = []
        self.ids: set[str] = set()

    def handle_starttag(self, tag, attrs):
        attrs = dict(attrs)
        if attrs.get("id"):
            self.ids.add(attrs["id"])
        if tag == "a" and attrs.get("name"):
            self.ids.add(attrs["name"])
        for key in ("href", "src"):
            if attrs.get(key) is not None:
                self.links.append(attrs[key])


def _parse(path: Path) -> _Page:
    page = _Page()
    page.feed(path.read_text(encoding="utf-8"))
    return page


@pytest.fixture(scope="module")
def site(tmp_path_factory) -> Path:
    out = tmp_path_factory.mktemp("site")
    run = subprocess.run(
        [sys.executable, "-m", "mkdocs", "build", "--strict", "--site-dir", str(out)],
        cwd=ROOT,
        capture_output=True,
        text=True,
    )
    assert run.returncode == 0, run.stderr[-4000:]
    return out


def _target(site: Path, page: Path, link: str) -> tuple[Path, str] | None:
    """The file of the site an internal link leads to, with its anchor; None for a link that
    leaves the site (a scheme, a host, mailto:)."""
    parts = urlsplit(link)
    if parts.scheme or parts.netloc:
        return None
    if not parts.path:
        return page, unquote(parts.fragment)
    path = (page.parent / unquote(parts.path)).resolve()
    if path.is_dir() or parts.path.endswith("/"):
        path = path / "index.html"
    return path, unquote(parts.fragment)


def test_the_site_opens_at_its_front_page(site):
    front = site / "index.html"
    assert front.is_file()
    text = front.read_text(encoding="utf-8")
    assert "topomap-testbed" in text and "<table" in text  # the results table


def test_every_internal_link_from_the_front_page_leads_somewhere(site):
    """Every page reachable from index.html, every link on it: the file exists inside the site,
    and an anchor on an HTML page is an id there."""
    seen: set[Path] = set()
    todo = [site / "index.html"]
    parsed: dict[Path, _Page] = {}
    broken = []
    while todo:
        page = todo.pop()
        if page in seen:
            continue
        seen.add(page)
        parsed[page] = parsed.get(page) or _parse(page)
        for link in parsed[page].links:
            found = _target(site, page, link)
            if found is None:
                continue
            path, anchor = found
            where = f"{page.relative_to(site)}: {link}"
            if not path.is_relative_to(site.resolve()) or not path.is_file():
                broken.append(where)
                continue
            if path.suffix == ".html":
                if anchor:
                    parsed[path] = parsed.get(path) or _parse(path)
                    if anchor not in parsed[path].ids:
                        broken.append(f"{where} (no id {anchor!r})")
                if path.name != "404.html":
                    todo.append(path)
    assert not broken, "links that lead nowhere:\n" + "\n".join(sorted(set(broken)))
    # the whole site is reachable from its front page: every page of the nav
    pages = {p for p in site.rglob("index.html")} - {site / "404.html"}
    assert {p.resolve() for p in pages} <= {p.resolve() for p in seen}


def test_the_nav_is_by_task(site):
    text = (site / "index.html").read_text(encoding="utf-8")
    sections = re.findall(r'class="caption-text">([^<]+)<', text)
    assert sections == [
        "Getting started",
        "Guides",
        "Results",
        "API reference",
        "Decisions",
        "Design",
    ]


def test_no_sphinx_role_is_left_on_a_page(site):
    left = {}
    for page in sorted(site.rglob("*.html")):
        found = ROLE.findall(page.read_text(encoding="utf-8"))
        if found:
            left[str(page.relative_to(site))] = len(found)
    assert not left, f"pages with literal Sphinx roles (role: count): {left}"


def _see_also():
    """``docs/hooks/see_also.py``, the griffe extension mkdocs.yml names, as a module."""
    spec = importlib.util.spec_from_file_location("see_also", ROOT / "docs/hooks/see_also.py")
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


def test_a_see_also_section_becomes_a_list_of_links():
    text = (
        "Summary.\n\nSee Also\n--------\n"
        "mapping.features.ScanFeatures, mapping.features.ImageFeatures : The features,\n"
        "    on two lines.\nsklearn.cluster.SpectralClustering : From outside.\n"
        "mapping.features.NoSuchThing\n\nExamples\n--------\n>>> 1\n"
    )
    assert _see_also().see_also_as_list(text) == (
        "Summary.\n\nSee Also\n--------\n"
        "- [`mapping.features.ScanFeatures`][mapping.features.scans.ScanFeatures], "
        "[`mapping.features.ImageFeatures`][mapping.features.images.ImageFeatures]: "
        "The features, on two lines.\n"
        "- `sklearn.cluster.SpectralClustering`: From outside.\n"
        "- `mapping.features.NoSuchThing`\n\nExamples\n--------\n>>> 1\n"
    )


def test_every_see_also_section_of_the_site_is_a_list_that_links(site):
    blocks = [
        block
        for page in sorted((site / "api").rglob("*.html"))
        for block in re.findall(
            r'<details class="see-also".*?</details>', page.read_text(encoding="utf-8"), re.S
        )
    ]
    assert len(blocks) > 30
    assert all("<ul>" in block for block in blocks)
    assert sum(
        "autorefs-internal" in block or "autorefs-external" in block for block in blocks
    ) > 0.9 * len(blocks)
