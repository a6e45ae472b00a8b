"""Result tables: typed columns and rows, rendered once as markdown, HTML, CSV or JSON.

An evaluation builds a `Table` (each `Column` says which key of a row it shows,
under which header, in which format) and every place that shows it (the command line, the HTML
report, the sweep's files, the benchmark's ``results.md``) renders that one table, so a column
is named and formatted in one place.
"""

from __future__ import annotations

import csv
import html
import io
import json
import math
import os
from collections.abc import Callable, Iterable, Mapping, Sequence
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from common.fileio import atomic_write_bytes, jsonable

__all__ = ["FORMATS", "Column", "Table"]

# what a missing value (None, NaN) reads as in each text format
_MISSING = {"md": "--", "html": "&ndash;", "csv": ""}
FORMATS = ("md", "html", "csv", "json")


@dataclass(frozen=True)
class Column:
    """One column: the row key it shows, its header, and how a value is written.

    ``fmt`` is a `format` spec (``".3f"``, ``"+.2f"``, ``"d"``, ``""``) or a function of
    the value returning the text; booleans read yes / no, sequences are joined with ``sep``.

    Parameters
    ----------
    key : str
        The row key it shows.
    header : str
        Its header.
    fmt : str or callable, default ""
        The format spec, or a function of the value returning the text.
    sep : str, default " / "
        What joins the items of a sequence.
    """

    key: str
    header: str
    fmt: str | Callable[[object], str] = ""
    sep: str = " / "

    def text(self, value) -> str | None:
        """Return the cell's text, or None for a missing value (each renderer writes its own).

        Parameters
        ----------
        value : object
            The row's value.

        Returns
        -------
        str or None
            The text.
        """
        if value is None or (isinstance(value, float | np.floating) and math.isnan(value)):
            return None
        if callable(self.fmt):
            return self.fmt(value)
        if isinstance(value, bool | np.bool_):
            return "yes" if value else "no"
        if isinstance(value, list | tuple):
            return self.sep.join(str(v) for v in value)
        return format(value, self.fmt)


@dataclass(frozen=True)
class Table:
    """Rows (mappings from column key to value) under typed `Column` s.

    Parameters
    ----------
    columns : tuple of Column
        The columns, with distinct keys.
    rows : tuple of Mapping
        The rows, each holding every column's key.
    caption : str, default ""
        The caption.
    notes : tuple of str, default ()
        Lines shown under the table (markdown, HTML) and kept in its JSON.
    """

    columns: tuple[Column, ...]
    rows: tuple[Mapping, ...]
    caption: str = ""
    notes: tuple[str, ...] = field(default=())

    def __post_init__(self) -> None:
        """Check that the column keys are distinct and that every row has them."""
        keys = [c.key for c in self.columns]
        if len(set(keys)) != len(keys):
            raise ValueError(f"columns must have distinct keys, got {keys}")
        for i, row in enumerate(self.rows):
            missing = [k for k in keys if k not in row]
            if missing:
                raise ValueError(f"rows[{i}] lacks the column key(s) {missing}")

    @classmethod
    def of(
        cls,
        columns: Iterable[Column],
        rows: Iterable[Mapping],
        caption: str = "",
        notes: Sequence[str] = (),
    ) -> Table:
        """Build a table from any iterables of columns, rows and notes.

        Parameters
        ----------
        columns : iterable of Column
            The columns.
        rows : iterable of Mapping
            The rows, from column key to value.
        caption : str, default ""
            The caption.
        notes : sequence of str, default ()
            Lines shown under the table.

        Returns
        -------
        Table
            The table.
        """
        return cls(tuple(columns), tuple(rows), caption, tuple(notes))

    def _cells(self, kind: str) -> list[list[str]]:
        return [
            [_MISSING[kind] if (t := c.text(row[c.key])) is None else t for c in self.columns]
            for row in self.rows
        ]

    def to_markdown(self) -> str:
        """Render the table as markdown: the caption in bold, the rows, then the notes.

        Returns
        -------
        str
            The markdown.
        """
        head = "| " + " | ".join(c.header for c in self.columns) + " |"
        rule = "|" + "|".join("---" for _ in self.columns) + "|"
        body = ["| " + " | ".join(cells) + " |" for cells in self._cells("md")]
        lines = [f"**{self.caption}**", ""] if self.caption else []
        lines += [head, rule, *body]
        if self.notes:
            lines += ["", *self.notes]
        return "\n".join(lines) + "\n"

    def to_html(self) -> str:
        """Render the table as an HTML ``<table>``, the notes as paragraphs after it.

        Returns
        -------
        str
            The HTML.
        """
        head = "".join(f"<th>{html.escape(c.header)}</th>" for c in self.columns)
        rows = [
            "<tr>"
            + "".join(
                f"<td>{cell if cell == _MISSING['html'] else html.escape(cell)}</td>"
                for cell in cells
            )
            + "</tr>"
            for cells in self._cells("html")
        ]
        caption = f"<caption>{html.escape(self.caption)}</caption>\n" if self.caption else ""
        notes = "".join(f"\n<p>{html.escape(n)}</p>" for n in self.notes)
        return (
            f"<table>\n{caption}<thead><tr>{head}</tr></thead>\n<tbody>\n"
            + "\n".join(rows)
            + "\n</tbody>\n</table>"
            + notes
        )

    def to_csv(self) -> str:
        """Render raw values under the column keys (a spreadsheet formats them itself).

        Returns
        -------
        str
            The CSV text.
        """
        buf = io.StringIO()
        writer = csv.writer(buf, lineterminator="\n")
        writer.writerow([c.key for c in self.columns])
        for row in self.rows:
            cells = (jsonable(row[c.key], finite=True) for c in self.columns)
            writer.writerow(["" if v is None else v for v in cells])
        return buf.getvalue()

    def to_json(self) -> dict:
        """Return columns, raw rows (only the columns' keys), caption and notes, JSON-ready.

        Returns
        -------
        dict
            The table as JSON values.
        """
        return {
            "caption": self.caption,
            "columns": [{"key": c.key, "header": c.header} for c in self.columns],
            "rows": [
                {c.key: jsonable(row[c.key], finite=True) for c in self.columns}
                for row in self.rows
            ],
            "notes": list(self.notes),
        }

    def render(self, kind: str) -> str:
        """Render the table in one of `FORMATS`.

        Parameters
        ----------
        kind : str
            "md", "html", "csv" or "json".

        Returns
        -------
        str
            The text.
        """
        if kind not in FORMATS:
            raise ValueError(f"kind must be one of {FORMATS}, got {kind!r}")
        if kind == "json":
            return json.dumps(self.to_json(), indent=2, allow_nan=False) + "\n"
        return {"md": self.to_markdown, "html": self.to_html, "csv": self.to_csv}[kind]()

    def write(
        self, stem: str | os.PathLike, kinds: Sequence[str] = ("md", "csv", "json")
    ) -> dict[str, Path]:
        """Write ``stem.md``, ``stem.csv``, ... each atomically (temporary file, rename).

        Parameters
        ----------
        stem : str or os.PathLike
            The path without the suffix; its folder is created when missing.
        kinds : sequence of str, default ("md", "csv", "json")
            The formats written.

        Returns
        -------
        dict of str to Path
            The path written per format.
        """
        stem = Path(stem)
        texts = {kind: self.render(kind) for kind in kinds}  # all rendered before any write
        stem.parent.mkdir(parents=True, exist_ok=True)
        paths = {}
        for kind, text in texts.items():
            paths[kind] = stem.with_name(f"{stem.name}.{kind}")
            atomic_write_bytes(paths[kind], text.encode())
        return paths
