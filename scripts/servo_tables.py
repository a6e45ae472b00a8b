"""The closed-loop servo results' tables, defined once.

``topomap servo-eval`` prints them as markdown and the HTML report renders the same tables
(``servo.task.evaluation.summarise`` results, one per world and policy; protocol results add
the tier and split).
"""

from __future__ import annotations

from collections.abc import Sequence

from scripts.tables import Column, Table

__all__ = ["pair_table", "summary_table"]


def _interval(ci) -> str:
    return f"[{ci[0]:.2f}, {ci[1]:.2f}]"


def _reasons(reasons: dict) -> str:
    return ", ".join(f"{k}: {v}" for k, v in reasons.items())


SUMMARY_COLUMNS = (
    Column("world", "world"),
    Column("policy", "policy"),
    Column("condition", "starts / split"),
    Column("episodes", "episodes", "d"),
    Column("success_rate", "success rate", ".2f"),
    Column("success_ci95", "Wilson 95%", _interval),
    Column("spl", "SPL", ".2f"),
    Column("final_distance", "final distance (m, median)", ".2f"),
    Column("final_heading_error_deg", "heading error (deg, median)", ".1f"),
    Column("steps", "steps (successes)", ".1f"),
    Column("collisions", "collisions", ".1f"),
    Column("act_ms", "act (ms)", ".2f"),
    Column("reasons", "end reasons", _reasons),
)
PAIR_COLUMNS = (
    Column("world", "world"),
    Column("policy", "policy"),
    Column("pair", "start -> target"),
    Column("episodes", "episodes", "d"),
    Column("success_rate", "success rate", ".2f"),
    Column("success_ci95", "Wilson 95%", _interval),
    Column("spl", "SPL", ".2f"),
    Column("final_distance", "final distance (m, median)", ".2f"),
    Column("collisions", "collisions", ".1f"),
)


def _condition(r: dict) -> str | None:
    if "tier" not in r:
        return None
    return f"{r['tier']}/{r['split']}" + ("/randomize" if r.get("randomize") else "")


def summary_table(results: Sequence[dict]) -> Table:
    """Tabulate one row per result (world and policy).

    The starts / split column appears only for protocol results (``servo.task.protocol``),
    which have them.

    Parameters
    ----------
    results : sequence of dict
        ``servo.task.evaluation.summarise`` results.

    Returns
    -------
    Table
        The summary table.
    """
    rows = [{**r, "condition": _condition(r)} for r in results]
    columns = SUMMARY_COLUMNS
    if all(r["condition"] is None for r in rows):
        columns = tuple(c for c in columns if c.key != "condition")
    return Table.of(columns, rows, "Closed-loop servoing per world and policy")


def pair_table(results: Sequence[dict]) -> Table:
    """Tabulate one row per (result, start manifold -> target manifold).

    Parameters
    ----------
    results : sequence of dict
        ``servo.task.evaluation.summarise`` results, with their ``per_pair`` entries.

    Returns
    -------
    Table
        The per-pair table.
    """
    rows = [
        {**s, "world": r["world"], "policy": r["policy"], "pair": pair}
        for r in results
        for pair, s in r["per_pair"].items()
    ]
    return Table.of(PAIR_COLUMNS, rows, "Per manifold pair (start -> target)")
