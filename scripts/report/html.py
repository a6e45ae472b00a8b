"""HTML pieces of the report: escaping, cell formatting, tables, figures, sections, the whole
page, and writing it after checking every file it references is beside it.
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
    return html.escape(str(value), quote=True)


def fmt(value, digits: int = 3) -> str:
    """A table cell: floats to ``digits`` decimals below 10 (fewer above: 12.35, 123.5), None
    as a dash, booleans as yes / no, lists comma-separated.
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
    """An HTML table with a caption; cells go through `fmt`."""
    head = "".join(f"<th>{esc(h)}</th>" for h in header)
    body = "\n".join("<tr>" + "".join(f"<td>{fmt(c)}</td>" for c in row) + "</tr>" for row in rows)
    return (
        f"<table>\n<caption>{esc(caption)}</caption>\n<thead><tr>{head}</tr></thead>\n"
        f"<tbody>\n{body}\n</tbody>\n</table>"
    )


def figure(src: str, caption: str) -> str:
    """An image by relative path, with a caption; clicking opens it full size."""
    src = esc(Path(src).as_posix())
    return (
        f'<figure><a href="{src}"><img src="{src}" alt="{esc(caption)}"></a>'
        f"<figcaption>{esc(caption)}</figcaption></figure>"
    )


def video(src: str, caption: str) -> str:
    """A video by relative path, played in the page (``<video controls>``), with a caption
    and a link to the file.
    """
    path = Path(src)
    src = esc(path.as_posix())
    return (
        f'<figure><video src="{src}" controls preload="metadata"></video>'
        f'<figcaption>{esc(caption)} (<a href="{src}">{esc(path.name)}</a>)</figcaption>'
        "</figure>"
    )


def section(anchor: str, title: str, *parts: str) -> str:
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
    """The whole page: a table of contents of the sections, then the sections."""
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
    """The local files an HTML page references (``src`` and ``href`` that are not anchors)."""
    refs = re.findall(r'(?:src|href)="([^"#][^"]*)"', page)
    return sorted({html.unescape(r) for r in refs})


def write_report(root: str | os.PathLike, page: str) -> Path:
    """Write ``index.html`` atomically after checking every file it references is in ``root``."""
    root = Path(root)
    missing = [r for r in referenced_files(page) if "://" in r or not (root / r).is_file()]
    if missing:
        raise FileNotFoundError(f"the report references files that are not in {root}: {missing}")
    path = root / INDEX
    atomic_write_bytes(path, page.encode())
    return path
