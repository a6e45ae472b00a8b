"""The held-out evaluation's summary.

Per family and task, the canonical world beside the held-out test worlds, with the gap:

* clustering error: mean over worlds with its bootstrap 95% interval, ours paired against
  scikit-learn's (the same worlds), and the worlds past `ERROR_TARGET`;
* grouping purity and groups per manifold: mean over worlds with its bootstrap interval;
* servo success per controller and start tier: the rate over every episode of every held-out
  world with its Wilson 95% interval, overall and by the junctions between start and target.
"""

from __future__ import annotations

import numpy as np

from scenes.families import SPLITS_VERSION
from scripts.heldout.cells import (
    MANIFOLD_Q,
    OURS_SCALED,
    Q_DIVISOR,
    manifold_errors,
    manifold_refusals,
)

__all__ = ["ERROR_TARGET", "format_summary", "summarise"]

ERROR_TARGET = 0.15  # a world's clustering error past this is a failure, as in the protocol
JUNCTIONS = (1, 2, 3)  # the servo rows' breakdown: junctions between start and target (3+)
MINUS_SKLEARN = " minus scikit-learn"  # the key of a method's paired difference


def _interval(values, seed: int = 0) -> dict:
    from scripts.manifold import bootstrap_mean

    return bootstrap_mean(np.asarray(values, float), np.random.default_rng(seed))


def _rate(records: list[dict]) -> dict | None:
    """Successes of ``records`` with the Wilson 95% interval (None: no episode)."""
    from servo.task import wilson_interval

    if not records:
        return None
    k, n = sum(bool(r["success"]) for r in records), len(records)
    lo, hi = wilson_interval(k, n)
    return {
        "successes": k,
        "n": n,
        "rate": k / n,
        "lo": lo,
        "hi": hi,
        "spl": float(np.mean([r["spl"] for r in records])),
    }


def _servo_records(cells: list[dict]) -> list[dict]:
    return [
        {**r, "world": c["world"]}
        for c in cells
        for r in c.get("tasks", {}).get("servo", {}).get("records", [])
    ]


def _servo(held: list[dict], canon: list[dict]) -> dict:
    """Rate held-out and canonical success per ``policy/tier``, and held-out by junctions."""
    held_r, canon_r = _servo_records(held), _servo_records(canon)
    out = {}
    for key in dict.fromkeys((r["policy"], r["tier"]) for r in held_r + canon_r):
        mine = [r for r in held_r if (r["policy"], r["tier"]) == key]
        theirs = [r for r in canon_r if (r["policy"], r["tier"]) == key]
        out["/".join(key)] = {
            "held_out": _rate(mine),
            "canonical": _rate(theirs),
            "by_junctions": {
                str(j): _rate([r for r in mine if min(r["junctions"], 3) == j]) for j in JUNCTIONS
            },
            "worlds": len({r["world"] for r in mine}),
        }
    return out


def summarise(cells: list[dict], frames: int) -> dict:
    """Summarise each task per family on the canonical world and over the held-out worlds.

    Parameters
    ----------
    cells : list of dict
        Cells of `scripts.heldout.cells.run_cell`.
    frames : int
        Frames per drive, recorded in the summary.

    Returns
    -------
    dict
        The summary: per family, the manifold, grouping and servo results.
    """
    from scripts.manifold import OURS, SKLEARN_DEFAULT

    out = {"splits_version": SPLITS_VERSION, "frames": frames, "q": MANIFOLD_Q, "families": {}}
    for family in sorted({c["family"] for c in cells}):
        canon = [c for c in cells if c["world"] == family]
        held = [c for c in cells if c["family"] == family and c["world"] != family]
        fam = {"worlds": sorted({c["world"] for c in held}), "manifold": {}, "grouping": {}}
        for method in (OURS, OURS_SCALED, SKLEARN_DEFAULT):
            e_held, e_can = manifold_errors(held, method), manifold_errors(canon, method)
            if len(e_held):
                fam["manifold"][method] = {
                    "held_out": _interval(e_held),
                    "canonical": float(e_can.mean()) if len(e_can) else None,
                    "worlds_past_target": int(np.sum(e_held > ERROR_TARGET)),
                    "worlds_refused": manifold_refusals(held, method),
                    "errors": e_held.tolist(),
                }
        theirs = manifold_errors(held, SKLEARN_DEFAULT)
        for method in (OURS, OURS_SCALED):
            ours = manifold_errors(held, method)
            if len(ours) and len(ours) == len(theirs):
                fam["manifold"][f"{method}{MINUS_SKLEARN}"] = _interval(ours - theirs)
        for key in ("purity", "max_groups_per_manifold"):
            held_v = [c["tasks"]["grouping"][key] for c in held if "grouping" in c["tasks"]]
            can_v = [c["tasks"]["grouping"][key] for c in canon if "grouping" in c["tasks"]]
            if held_v:
                fam["grouping"][key] = {
                    "held_out": _interval(held_v),
                    "canonical": float(np.mean(can_v)) if can_v else None,
                    "values": held_v,
                }
        fam["servo"] = _servo(held, canon)
        out["families"][family] = fam
    return out


def _label(method: str) -> str:
    """Name a clustering method in the tables: ours with its Q rule."""
    from scripts.manifold import OURS

    return {OURS: f"ours, Q = {MANIFOLD_Q}", OURS_SCALED: f"ours, Q = n / ({Q_DIVISOR} K)"}.get(
        method, method
    )


def _fmt(s: dict, pct: bool) -> str:
    f = (lambda v: f"{100 * v:.1f}%") if pct else (lambda v: f"{v:.3f}")
    return f"{f(s['mean'])} [{f(s['lo'])}, {f(s['hi'])}]"


def _row(family, task, method, canonical: float | None, held: dict, pct: bool) -> str:
    """Write one row of the mapping table; the gap in points (rates) or units (other values)."""
    if canonical is None:
        canon = gap = ""
    elif pct:
        canon, gap = f"{100 * canonical:.1f}%", f"{100 * (held['mean'] - canonical):+.1f} points"
    else:
        canon, gap = f"{canonical:.3f}", f"{held['mean'] - canonical:+.3f}"
    return f"| {family} | {task} | {method} | {canon} | {_fmt(held, pct)} | {gap} | {held['n']} |"


def _rate_text(r: dict | None) -> str:
    if r is None:
        return ""
    pct = f"{100 * r['rate']:.0f}% [{100 * r['lo']:.0f}, {100 * r['hi']:.0f}]"
    return f"{r['successes']}/{r['n']} ({pct})"


def format_summary(summary: dict) -> str:
    """Write the summary as markdown tables.

    A mapping table (canonical, held-out and gap per family, task and method) and, where servo
    episodes ran, a servo table (success per controller and tier, canonical beside held-out,
    and held-out by junctions between start and target).

    Parameters
    ----------
    summary : dict
        A summary of `summarise`.

    Returns
    -------
    str
        The markdown.
    """
    lines = [
        "| family | task | method | canonical world | held-out worlds [95% interval] | gap | n |",
        "|---|---|---|---|---|---|---|",
    ]
    servo = []
    for family, fam in summary["families"].items():
        for method, m in fam["manifold"].items():
            if method.endswith(MINUS_SKLEARN):
                name = _label(method.removesuffix(MINUS_SKLEARN)) + MINUS_SKLEARN
                lines.append(_row(family, "clustering error", name, None, m, True))
            else:
                lines.append(
                    _row(
                        family,
                        "clustering error",
                        _label(method),
                        m["canonical"],
                        m["held_out"],
                        True,
                    )
                )
        for key, g in fam["grouping"].items():
            task = f"grouping {key.replace('_', ' ')}"
            method = "partitioner (odometry + ICP)"
            lines.append(_row(family, task, method, g["canonical"], g["held_out"], False))
        for key, s in fam.get("servo", {}).items():
            policy, tier = key.split("/")
            h, c = s["held_out"], s["canonical"]
            gap = "" if h is None or c is None else f"{100 * (h['rate'] - c['rate']):+.0f} points"
            by = " | ".join(_rate_text(s["by_junctions"].get(str(j))) for j in JUNCTIONS)
            servo.append(
                f"| {family} | {policy} | {tier} | {_rate_text(c)} | {_rate_text(h)} "
                f"| {gap} | {by} | {s['worlds']} |"
            )
    if servo:
        lines += [
            "",
            "| family | controller | start tier | canonical world | held-out worlds | gap | "
            + " | ".join(("1 junction", "2 junctions", "3 or more")[j - 1] for j in JUNCTIONS)
            + " | worlds |",
            "|---|---|---|---|---|---|" + "---|" * len(JUNCTIONS) + "---|",
            *servo,
        ]
    return "\n".join(lines) + "\n"
