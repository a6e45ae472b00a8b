"""The observation grouping's result tables (``scripts.grouping.evaluate``), defined once.

The command line prints them as markdown and the HTML report renders the same tables.
"""

from __future__ import annotations

from scripts.tables import Column, Table

__all__ = ["comparison_table", "grouping_table"]

NO_LABELS = "no ground-truth labels: groups are not scored (purity, ARI, drift and targets: --)"

GROUPING_COLUMNS = (
    Column("case", "case"),
    Column("poses", "poses"),
    Column("frames", "frames", "d"),
    Column("groups", "groups", "d"),
    Column("purity", "purity", ".3f"),
    Column("ari", "ARI", "+.3f"),
    Column("groups_per_manifold", "groups per manifold (majority)"),
    Column("max_groups_touching", "max touching", "d"),
    Column("max_drift_m", "drift (m)", ".2f"),
    Column("seconds", "time (s)", ".2f"),
    Column("meets_targets", "targets", lambda met: "met" if met else "missed"),
)
COMPARISON_COLUMNS = (
    Column("world", "world"),
    Column("method", "method / sensor"),
    Column("groups", "groups", "d"),
    Column("purity", "purity", ".3f"),
    Column("ari", "ARI", "+.3f"),
    Column("max_groups_per_manifold", "max groups per manifold", "d"),
    Column("seconds", "time (s)", ".2f"),
)


def grouping_table(result: dict) -> Table:
    """Build the grouping table: one row per case (world, and its loop) and pose source.

    Unscored cells (no ground truth) read as missing.

    Parameters
    ----------
    result : dict
        ``evaluate_grouping``'s result.

    Returns
    -------
    Table
        The table.
    """
    rows = []
    for part in ("default", "loop"):
        for world, entry in result.get(part, {}).items():
            for variant, s in entry.items():
                if not isinstance(s, dict):  # the figure names beside the scores
                    continue
                per = tuple(s["groups_per_manifold"].values()) or None
                case = f"{world}-loop" if part == "loop" else world
                rows.append({**s, "case": case, "poses": variant, "groups_per_manifold": per})
    notes = () if result.get("ground_truth", True) else (NO_LABELS,)
    return Table.of(
        GROUPING_COLUMNS, rows, "Laser observation grouping per world and pose source", notes
    )


def comparison_table(result: dict) -> Table:
    """Build the table of both methods (min-Ncut, manifold clustering) on both sensors.

    Parameters
    ----------
    result : dict
        ``evaluate_grouping``'s result, with its ``compare`` entries per world.

    Returns
    -------
    Table
        One row per world, method and sensor.
    """
    rows = [
        {**s, "world": world, "method": name}
        for world, entries in result.get("compare", {}).items()
        for name, s in entries.items()
    ]
    return Table.of(COMPARISON_COLUMNS, rows, "Both methods on both sensors (method / sensor)")
