"""The held-out worlds' tables, from the committed ``topomap heldout`` file.

README's block (canonical beside held-out, with the gap) and the page's per-world table.

The summary is recomputed from the file's cells (``scripts.heldout.summarise``), so the tables
show what the cells hold, whatever summary the file carries.
"""

from __future__ import annotations

from pathlib import Path

from common.fileio import read_json
from scripts.tables import Column, Table

__all__ = ["HELDOUT_SOURCE", "heldout_cells", "heldout_summary", "heldout_worlds"]

HELDOUT_SOURCE = "worlds/heldout.json"


def heldout_cells(path: Path) -> tuple[list[dict], int]:
    """Read the cells of a ``topomap heldout`` file and their frames per drive.

    Parameters
    ----------
    path : Path
        The file.

    Returns
    -------
    tuple of (list of dict, int)
        The cells and their frames per drive.

    Raises
    ------
    ValueError
        If the file holds no list of cells, or cells of several frame counts.
    """
    data = read_json(path)
    cells = data.get("cells") if isinstance(data, dict) else None
    if not isinstance(cells, list) or not cells or not all(isinstance(c, dict) for c in cells):
        raise ValueError(f"{path}: 'cells' must be a non-empty list of held-out cells")
    frames = {c.get("frames") for c in cells}
    if len(frames) != 1:
        raise ValueError(f"{path}: cells of one frame count expected, found {sorted(frames)}")
    return cells, int(frames.pop())


def heldout_summary(root: Path, sources) -> str:
    """Write the summary tables (``scripts.heldout.format_summary``) of the file, with a legend.

    Parameters
    ----------
    root : Path
        The folder of the result files.
    sources : sequence of str
        The section's sources; the first is the ``topomap heldout`` file.

    Returns
    -------
    str
        The markdown.
    """
    from scripts.heldout import format_summary, summarise

    cells, frames = heldout_cells(root / sources[0])
    legend = (
        "Canonical world: the family's hand-built world (seed 0); held-out worlds: the "
        "family's first test worlds (seeds from 11,000, skipping those that repeat a training "
        "world's structure), never used for tuning. Clustering: HSV histograms, even frames "
        "build the map and odd frames test it, K the world's manifold count; grouping: every "
        f"drive in one graph, odometry + ICP; {frames} frames per drive, dataset seed 0. "
        "Servo: a map built from the world's own dataset, the protocol's test episodes; "
        "success over every episode of every world with its Wilson 95% interval, then by "
        "the junctions between start and target manifold. Intervals of means: bootstrap over "
        "worlds."
    )
    return f"{format_summary(summarise(cells, frames))}\n{legend}\n"


def heldout_worlds(root: Path, sources) -> str:
    """Tabulate one row per world: its size and each task's number.

    Parameters
    ----------
    root : Path
        The folder of the result files.
    sources : sequence of str
        The section's sources; the first is the ``topomap heldout`` file.

    Returns
    -------
    str
        The markdown table.
    """
    from scripts.manifold import OURS, SKLEARN_DEFAULT

    cells, _ = heldout_cells(root / sources[0])
    rows = []
    for c in sorted(cells, key=lambda c: (c["family"], ":" in c["world"], c["world"])):
        t = c.get("tasks", {})
        err = {r["method"]: r["test_error"] for r in t.get("manifold", {}).get("rows", [])}
        servo = t.get("servo", {}).get("records", [])
        by = {p: [r["success"] for r in servo if r["policy"] == p] for p in ("servo", "signal")}
        rows.append(
            {
                "world": c["world"],
                "manifolds": len(c["manifolds"]),
                "depth": max(c["junctions"].values()),
                "ours": err.get(OURS),
                "sklearn": err.get(SKLEARN_DEFAULT),
                "purity": t.get("grouping", {}).get("purity"),
                **{p: f"{sum(ok)}/{len(ok)}" if ok else "" for p, ok in by.items()},
            }
        )
    pct = lambda v: "" if v is None else f"{100 * v:.1f}%"  # noqa: E731
    columns = (
        Column("world", "world"),
        Column("manifolds", "manifolds", "d"),
        Column("depth", "junctions deep", "d"),
        Column("ours", "clustering error, ours", pct),
        Column("sklearn", "clustering error, scikit-learn", pct),
        Column("purity", "grouping purity", lambda v: "" if v is None else f"{v:.3f}"),
        Column("servo", "ManifoldServo successes"),
        Column("signal", "SignalServo successes"),
    )
    return Table.of(columns, rows).to_markdown()
