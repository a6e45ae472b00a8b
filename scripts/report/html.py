"""HTML pieces of the report.

Escaping, cell formatting, tables, figures, sections, the whole page, and writing it after
checking every file it references is beside it.
"""

from __future__ import annotations

import html
import os
import re
from collections.abc import Iterable, Sequence
from pathlib import Path

import numpy as np

from common.fileio import atomic_write_bytes

__all__ = [
    "INDEX",
    "STYLE",
    "build_html",
    "esc",
    "figure",
    "fmt",
    "referenced_files",
    "section",
    "table",
    "video",
    "write_report",
]

INDEX = "index.html"


def esc(value) -> str:
    """Escape ``str(value)`` for HTML text and attributes (quotes included).

    Parameters
    ----------
    value : object
        The value.

    Returns
    -------
    str
        The escaped text.
    """
    return html.escape(str(value), quote=True)


def fmt(value, digits: int = 3) -> str:
    """Format a table cell as HTML.

    Floats to ``digits`` decimals below 10 (fewer above: 12.35, 123.5), None as a dash,
    booleans as yes / no, lists comma-separated.

    Parameters
    ----------
    value : object
        The cell's value.
    digits : int, default 3
        Decimals of a float below 10.

    Returns
    -------
    str
        The cell's HTML.
    """
    if value is None:
        return "&ndash;"
    if isinstance(value, bool | np.bool_):
        return "yes" if value else "no"
    if isinstance(value, float | np.floating):
        size = abs(float(value))
        return f"{value:.{max(0, digits - (size >= 10) - (size >= 100))}f}"
    if isinstance(value, list | tuple):
        return esc(", ".join(map(str, value)))
    return esc(value)


def table(caption: str, header: Sequence[str], rows: Iterable[Sequence]) -> str:
    """Build an HTML table with a caption; cells go through `fmt`.

    Parameters
    ----------
    caption : str
        The caption.
    header : sequence of str
        The column headers.
    rows : iterable of sequence
        The rows' cells.

    Returns
    -------
    str
        The HTML.
    """
    head = "".join(f"<th>{esc(h)}</th>" for h in header)
    body = "\n".join("<tr>" + "".join(f"<td>{fmt(c)}</td>" for c in row) + "</tr>" for row in rows)
    return (
        f"<table>\n<caption>{esc(caption)}</caption>\n<thead><tr>{head}</tr></thead>\n"
        f"<tbody>\n{body}\n</tbody>\n</table>"
    )


def figure(src: str, caption: str) -> str:
    """Show an image by relative path, with a caption; clicking opens it full size.

    Parameters
    ----------
    src : str
        The image's path, relative to the page.
    caption : str
        The caption.

    Returns
    -------
    str
        The ``<figure>`` HTML.
    """
    src = esc(Path(src).as_posix())
    return (
        f'<figure><a href="{src}"><img src="{src}" alt="{esc(caption)}"></a>'
        f"<figcaption>{esc(caption)}</figcaption></figure>"
    )


def video(src: str, caption: str) -> str:
    """Show a video by relative path, played in the page (``<video controls>``).

    It has a caption and a link to the file.

    Parameters
    ----------
    src : str
        The video's path, relative to the page.
    caption : str
        The caption.

    Returns
    -------
    str
        The ``<figure>`` HTML.
    """
    path = Path(src)
    src = esc(path.as_posix())
    return (
        f'<figure><video src="{src}" controls preload="metadata"></video>'
        f'<figcaption>{esc(caption)} (<a href="{src}">{esc(path.name)}</a>)</figcaption>'
        "</figure>"
    )


def section(anchor: str, title: str, *parts: str) -> str:
    """Wrap ``parts`` in a ``<section>`` with an anchor and a heading.

    Parameters
    ----------
    anchor : str
        The section's id.
    title : str
        Its heading.
    *parts : str
        Its HTML pieces, one per line.

    Returns
    -------
    str
        The HTML.
    """
    return (
        f'<section id="{esc(anchor)}">\n<h2>{esc(title)}</h2>\n' + "\n".join(parts) + "\n</section>"
    )


STYLE = """
body { font-family: sans-serif; max-width: 1200px; margin: 1em auto; padding: 0 1em; }
table { border-collapse: collapse; margin: 1em 0; font-size: 0.9em; }
caption { text-align: left; font-weight: bold; padding: 0.3em 0; }
th, td { border: 1px solid #bbb; padding: 0.2em 0.5em; text-align: left; }
th { background: #eee; }
figure { display: inline-block; margin: 0.5em; vertical-align: top; }
figure img { max-width: 560px; max-height: 420px; border: 1px solid #ccc; }
figure video { max-width: 100%; border: 1px solid #ccc; }
figcaption { font-size: 0.85em; max-width: 560px; }
"""


def build_html(title: str, sections: Sequence[str], summary: str = "") -> str:
    """Build the whole page: a table of contents of the sections, then the sections.

    Parameters
    ----------
    title : str
        The page's title and heading.
    sections : sequence of str
        The sections of `section`.
    summary : str, default ""
        HTML shown before the table of contents.

    Returns
    -------
    str
        The page.
    """
    toc = "".join(
        f'<li><a href="#{a}">{t}</a></li>'
        for a, t in (
            re.search(r'<section id="([^"]+)">\n<h2>([^<]*)</h2>', s).groups() for s in sections
        )
    )
    return (
        f'<!DOCTYPE html>\n<html lang="en">\n<head>\n<meta charset="utf-8">\n'
        f"<title>{esc(title)}</title>\n<style>{STYLE}</style>\n</head>\n<body>\n"
        f"<h1>{esc(title)}</h1>\n{summary}\n<ul>{toc}</ul>\n"
        + "\n".join(sections)
        + "\n</body>\n</html>\n"
    )


def referenced_files(page: str) -> list[str]:
    """List the local files an HTML page references (``src`` and ``href`` not anchors).

    Parameters
    ----------
    page : str
        The HTML.

    Returns
    -------
    list of str
        The references, sorted, each once.
    """
    refs = re.findall(r'(?:src|href)="([^"#][^"]*)"', page)
    return sorted({html.unescape(r) for r in refs})


def write_report(root: str | os.PathLike, page: str) -> Path:
    """Write ``index.html`` atomically after checking every file it references is in ``root``.

    Parameters
    ----------
    root : str or os.PathLike
        The report folder.
    page : str
        The HTML.

    Returns
    -------
    Path
        The page's path.

    Raises
    ------
    FileNotFoundError
        If the page references a file that is not in ``root`` or a URL.
    """
    root = Path(root)
    missing = [r for r in referenced_files(page) if "://" in r or not (root / r).is_file()]
    if missing:
        raise FileNotFoundError(f"the report references files that are not in {root}: {missing}")
    path = root / INDEX
    atomic_write_bytes(path, page.encode())
    return path
