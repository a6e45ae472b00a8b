"""A griffe extension for the API pages: "See Also" sections as lists of links.

A numpydoc "See Also" section renders as a list whose names link to their pages.

The docstrings keep numpydoc's form (``name[, name] : description``, a description's further
lines indented), which ``help()`` shows as written; griffe's numpy parser reads the section as
plain text, so without this extension a page shows its entries as one run-on paragraph. Each
entry becomes a list item, and each name a cross-reference to the object's canonical path
(where it is defined) when the object is on an API page (a ``::: path`` directive of
``docs/api/``, or a public member of one); any other name, one from outside
(``sklearn.cluster.SpectralClustering``) included, stays code. ``mkdocs build --strict`` fails on a
linked name that no API page renders.
"""

from __future__ import annotations

import importlib
import re
import sys
from functools import cache
from pathlib import Path
from types import ModuleType

from griffe import Extension

ROOT = Path(__file__).resolve().parents[2]
PACKAGES = ("common", "scenes", "sim", "mapping", "servo", "scripts")
DIRECTIVE = re.compile(r"^::: ([\w.]+)\s*$", re.M)
HEADER = re.compile(r"^See Also\n-{3,}\n", re.M)
NEXT_SECTION = re.compile(r"^\S[^\n]*\n-{3,}$", re.M)


def canonical(name: str) -> str | None:
    """Return the path where ``name`` is defined.

    Parameters
    ----------
    name : str
        A dotted name, ``package.module.Object[.member]``.

    Returns
    -------
    str or None
        The defining path, or None when ``name`` is not one of the repository's objects or
        does not import.
    """
    if name.split(".")[0] not in PACKAGES:
        return None
    if str(ROOT) not in sys.path:
        sys.path.insert(0, str(ROOT))  # the checkout's own code, as mkdocstrings reads it
    parts = name.split(".")
    for cut in range(len(parts), 0, -1):
        try:
            value = importlib.import_module(".".join(parts[:cut]))
        except ImportError:
            continue
        path = value.__name__
        try:
            for part in parts[cut:]:
                owner, value = value, getattr(value, part)
                if isinstance(value, ModuleType):
                    path = value.__name__
                    continue
                qualname = getattr(value, "__qualname__", None)
                module = getattr(value, "__module__", None)
                if isinstance(qualname, str) and isinstance(module, str):
                    path = f"{module}.{qualname}"
                else:  # a constant: where it was found
                    path = f"{getattr(owner, '__name__', path)}.{part}"
        except AttributeError:
            return None
        return path
    return None


@cache
def rendered() -> tuple[str, ...]:
    """Return the objects the API pages render (their ``::: path`` directives)."""
    pages = sorted((ROOT / "docs" / "api").glob("*.md"))
    return tuple(path for page in pages for path in DIRECTIVE.findall(page.read_text()))


def on_a_page(path: str) -> bool:
    """Whether ``path`` is rendered: an API page's object, or a public member of one."""
    return any(
        path == top
        or (
            path.startswith(top + ".")
            and not any(p.startswith("_") for p in path[len(top) :].split("."))
        )
        for top in rendered()
    )


def entry(names: str, description: str) -> str:
    """Return one "See Also" line as a list item whose names link to their pages."""
    links = []
    for name in (n.strip().removesuffix("()") for n in names.split(",")):
        target = canonical(name)
        target = target if target and on_a_page(target) else None
        links.append(f"[`{name}`][{target}]" if target else f"`{name}`")
    return "- " + ", ".join(links) + (f": {description}" if description else "")


def see_also_as_list(text: str) -> str:
    """``text`` (a docstring) with the entries of its See Also section as a Markdown list."""
    header = HEADER.search(text)
    if header is None:
        return text
    start = header.end()
    following = NEXT_SECTION.search(text, start)
    end = following.start() if following else len(text)
    items: list[tuple[str, list[str]]] = []
    for line in text[start:end].splitlines():
        if not line.strip():
            continue
        if line[0].isspace() and items:  # a description's further line
            items[-1][1].append(line.strip())
            continue
        names, _, description = line.partition(" : ")
        items.append((names, [description.strip()] if description.strip() else []))
    block = "\n".join(entry(names, " ".join(words)) for names, words in items)
    return text[:start] + block + ("\n\n" if following else "\n") + text[end:]


class SeeAlsoLinks(Extension):
    """Rewrites each docstring's See Also section before it is parsed."""

    def on_object(self, *, obj, **kwargs) -> None:
        """Rewrite the "See Also" section of ``obj``'s docstring as a list of links."""
        docstring = obj.docstring
        if docstring is not None and "See Also" in docstring.value:
            docstring.value = see_also_as_list(docstring.value)
