"""One builder per section of the report page, each of a plain dict (the stage's result).

Each can thus be tested on fake inputs; paths in the dicts are relative to the report's root.
"""

from __future__ import annotations

from collections.abc import Sequence
from pathlib import Path

import numpy as np

from scripts.grouping import comparison_table, grouping_table
from scripts.report.html import esc, figure, fmt, section, table, video
from scripts.servo_tables import pair_table, summary_table

__all__ = [
    "PAPER",
    "section_grouping",
    "section_leaderboards",
    "section_manifold",
    "section_protocol",
    "section_reproduce",
    "section_servo",
    "section_summary",
    "section_worlds",
]

PAPER = {
    "manifold": "Grudic & Mulligan, topological mapping with visual manifolds",
    "grouping": "Blanco et al., observation grouping by sensed-space overlap",
}


def section_summary(lines: Sequence[dict]) -> str:
    """Build the page's opening summary: one row per line of the run's summary.

    Each row gives the task, what its number is, the number with its 95% interval, the target
    and whether the number meets it.

    Parameters
    ----------
    lines : sequence of dict
        The lines of ``scripts.report.summary.summarise_run``.

    Returns
    -------
    str
        The section's HTML.
    """
    rows = []
    for line in lines:
        value, interval = line["value"], line["interval"]
        if value is None:
            shown = "not scored"
        elif interval is None:
            shown = fmt(value)
        else:
            lo, hi = (fmt(v) for v in interval)
            shown = f"{fmt(value)} [{lo}, {hi}] ({line['interval_kind']})"
        target = line["target"] or "no target"
        rows.append([line["task"], line["measure"], shown, target, line["meets"], line["detail"]])
    return section(
        "summary",
        "Summary",
        table(
            "Each task's headline number against its target (the worst world where there are "
            "several; met: the number itself reaches the target, the interval says how surely)",
            ("task", "measure", "value [95% interval]", "target", "meets target", "details"),
            rows,
        ),
    )


def section_worlds(result: dict) -> str:
    """Build the worlds section: top-down views, per manifold samples, the gallery.

    Parameters
    ----------
    result : dict
        {"topdown": {world: path}, "manifolds": {manifold: {"image", "frames"}}}, and
        optionally "gallery": {family: path} (paths relative to the report's root).

    Returns
    -------
    str
        The section's HTML.
    """
    parts = [
        "<p>Top-down views: manifold regions in colour, obstacles dark, the dataset's true "
        "trajectories on them. Per manifold: three camera frames spread over its stretch of "
        "the route and, right, a 16 m square of the map around the robot at the middle frame "
        "with its laser scan (red: every 8th ray and every hit).</p>",
        '<div class="row">',
        *(figure(p, f"{w}: top-down view and trajectories") for w, p in result["topdown"].items()),
        "</div>",
    ]
    for name, entry in result["manifolds"].items():
        frames = ", ".join(f"{s} #{i}" for s, i in entry["frames"])
        parts.append(figure(entry["image"], f"{name}: frames {frames}; laser on the map"))
    if result.get("gallery"):
        parts.append(
            "<p>Generated worlds (<code>FAMILY:SEED</code>, the first 12 training worlds of "
            "each family): manifolds in colour, obstacles dark, the teleop routes red. The "
            "methods are scored on held-out test worlds of the same families.</p>"
        )
        parts += [figure(p, f"{f} family: generated worlds") for f, p in result["gallery"].items()]
    return section("worlds", "The worlds", *parts)


def section_manifold(result: dict) -> str:
    """Build the manifold-clustering section: synthetic and real tables, and the figures.

    Parameters
    ----------
    result : dict
        The result of ``scripts.manifold.reproduce.reproduce`` (paths relative to the root).

    Returns
    -------
    str
        The section's HTML.
    """
    synthetic = table(
        "Synthetic sets: clustering error, ours beside the paper's claim",
        ("set", "method", "error", "paper"),
        ([r["set"], r["method"], r["error"], r.get("paper_claim")] for r in result["synthetic"]),
    )
    real = table(
        "Simulated image and laser sequences: clustering error on the map (train: every "
        "second frame) and on the other frames (test), beside the paper's",
        ("sensor", "features", "method", "train error", "test error", "paper"),
        (
            [
                r["sensor"],
                r["features"],
                r["method"],
                r["train_error"],
                r.get("test_error"),
                r.get("paper_error"),
            ]
            for r in result["real"]
        ),
    )
    figs = [figure(p, Path(p).stem.replace("_", " ")) for p in result.get("figures", [])]
    return section(
        "manifold",
        f"Manifold clustering ({PAPER['manifold']})",
        "<p>Error: the fraction of points in the wrong cluster after the best matching of "
        "clusters to true manifolds. See docs/guides/manifold-clustering.md for the choices "
        "made where the paper is ambiguous.</p>" + _no_labels_note(result),
        synthetic,
        real,
        '<div class="row">',
        *figs,
        "</div>",
    )


SPREAD = ("min", "median", "max")
PROTOCOL_HOWTO = (
    "collect the seeds (<code>topomap collect --world all --seed S --out ROOT/m-data-S</code>, "
    "S = 0 ... 10), run <code>python -m scripts.manifold.protocol --root ROOT --out DIR "
    "--seeds 1 2 3 4 5 6 7 8 9 10</code> (about a minute per seed and condition on 2 cores) "
    "and give <code>topomap run --protocol DIR</code>"
)


def section_protocol(result: dict) -> str:
    """Build the section of the frozen protocol's errors over dataset seeds.

    One table per condition and features: a row per method, a column per seed (the dev seed
    first), then min / median / max and the mean with its bootstrap 95% interval over the fresh
    seeds. Without a source, the section says how to make one.

    Parameters
    ----------
    result : dict
        The result of ``stage_protocol``: {"source": folder or None, "rows": the rows of
        ``scripts.manifold.protocol.summarize``}.

    Returns
    -------
    str
        The section's HTML.
    """
    intro = (
        "<p>The manifold-clustering tables above are <strong>one dataset seed</strong>: seed 0, "
        "the dev seed on which the features and the merge rule were chosen. What the method "
        "does on other seeds is the frozen protocol's job: the same settings on fresh dataset "
        "seeds, beside the label-free baselines a user would pick (see docs/guides/"
        "manifold-clustering.md, &ldquo;The frozen multi-seed protocol&rdquo;).</p>"
    )
    if result.get("source") is None:
        return section(
            "seeds",
            "Manifold clustering: the spread over dataset seeds",
            intro,
            "<p><strong>Not part of this run</strong>: ten more datasets and their fits take "
            "longer than the run's 10 minutes on 2 cores. To show it here, "
            + PROTOCOL_HOWTO
            + ".</p>",
        )
    groups: dict[tuple[str, str], list[dict]] = {}
    for r in result["rows"]:
        groups.setdefault((r["condition"], r["features"]), []).append(r)
    tables = []
    for (condition, features), rows in groups.items():
        seeds = sorted({s for r in rows for s in r["seeds"]})
        body = []
        for r in rows:
            by_seed = dict(zip(r["seeds"], r["errors"], strict=True))
            errors, stats = r["errors"], r["summary"]
            spread = [min(errors), float(np.median(errors)), max(errors)] if errors else [None] * 3
            mean = (
                None
                if stats is None
                else f"{fmt(stats['mean'])} [{fmt(stats['lo'])}, {fmt(stats['hi'])}]"
            )
            body.append(
                [r["method"], r["dev_error"], *(by_seed.get(s) for s in seeds), *spread, mean]
            )
        mean_header = f"mean [95% CI], {len(seeds)} fresh seeds"
        tables.append(
            table(
                f"Test error by dataset seed: condition {condition}, features {features}",
                ("method", "dev seed 0", *(f"seed {s}" for s in seeds), *SPREAD, mean_header),
                body,
            )
        )
    return section(
        "seeds",
        "Manifold clustering: the spread over dataset seeds",
        intro,
        f"<p>From <code>{esc(result['source'])}</code> ({result.get('cells', '?')} cells), "
        "written by <code>scripts.manifold.protocol</code>, not recomputed by this run.</p>"
        + "".join(f"<p>{esc(k)}: {esc(v)}</p>" for k, v in result.get("made", {}).items()),
        *tables,
    )


def section_grouping(result: dict, prefix: str = "") -> str:
    """Build the observation-grouping section: its tables and figures.

    The tables are ``scripts.grouping.tables``', the ones the command line prints.

    Parameters
    ----------
    result : dict
        The result of ``scripts.grouping.evaluate.evaluate_grouping``.
    prefix : str, default ""
        The folder of the figures, relative to the report's root.

    Returns
    -------
    str
        The section's HTML.
    """
    targets = result.get("settings", {}).get("targets", {})
    purity_min, max_groups = targets.get("purity_min"), targets.get("max_groups_per_manifold")
    parts = [
        "<p>Each world's three sequences are grouped together in one observation graph; groups "
        f"are scored against the true manifolds. Targets: purity &ge; "
        f"{fmt(purity_min, 2)}, at most {fmt(max_groups)} "
        "groups per manifold. See docs/guides/observation-grouping.md.</p>"
        + _no_labels_note(result),
        grouping_table(result).to_html(),
    ]
    if result.get("compare"):
        parts.append(comparison_table(result).to_html())
    parts.append('<div class="row">')
    for name in result.get("figures", []):
        parts.append(figure(f"{prefix}{name}", Path(name).stem.replace("_", " ")))
    parts.append("</div>")
    return section("grouping", f"Observation grouping ({PAPER['grouping']})", *parts)


def _no_labels_note(result: dict) -> str:
    """Note results of a dataset without ground truth (imported from a robot's log)."""
    if result.get("ground_truth", True):
        return ""
    return (
        "<p><strong>No ground-truth labels</strong> in this dataset (imported from a robot's "
        "log): the methods ran and their clusters and figures are here, but nothing can be "
        "scored (&ndash;).</p>"
    )


def section_servo(results: Sequence[dict], videos: dict[str, list[str]]) -> str:
    """Build the closed-loop servoing section: tables, trajectory plots and videos.

    Parameters
    ----------
    results : sequence of dict
        ``servo.task.evaluation.evaluate`` dicts (with ``plot`` relative to the root).
    videos : dict of str to list of str
        Per "world/policy", video paths relative to the root.

    Returns
    -------
    str
        The section's HTML.
    """
    summary, pairs = summary_table(results).to_html(), pair_table(results).to_html()
    parts = [
        "<p>The servo benchmark's test split (never used for tuning): each episode starts the "
        "robot near a stored view of one manifold (<i>view</i>) or anywhere in its free space "
        "with any heading (<i>anywhere</i>) and gives it a stored view on another manifold to "
        "reach; success is ending within 0.5 m and 20 deg of that view's pose, with its Wilson "
        "95% interval. SPL weighs success by the shortest free-space path over the path driven. "
        "Policies: <i>servo</i> (laser and images on a map built from the sensed data), "
        "<i>signal</i> (camera and odometry only, servoing by F^j(k) of eq. 13 through "
        "waypoint views: the paper's Section II-G), the oracle (the true pose on the shortest "
        "path: the upper bound), and random commands or greedy probing of F when asked for. "
        "See docs/guides/servo.md.</p>",
        summary,
        pairs,
        '<div class="row">',
    ]
    for r in results:
        if r.get("plot"):
            parts.append(
                figure(
                    r["plot"],
                    f"{r['world']} / {r['policy']}"
                    + (f" / {r['tier']}" if r.get("tier") else "")
                    + ": trails (green: success, red: "
                    "failure), targets as outlines",
                )
            )
    parts.append("</div>")
    clips = [video(v, key) for key, paths in videos.items() for v in paths]
    if clips:
        parts += [
            "<p>Episode videos: the robot's camera view beside the top-down map.</p>",
            '<div class="row">',
            *clips,
            "</div>",
        ]
    return section("servo", "Closed-loop servoing", *parts)


def section_reproduce(info: dict) -> str:
    """Build the section of what reproduces the report: command, settings, versions, timings.

    Parameters
    ----------
    info : dict
        {"command", "settings", "versions", "machine", "commit", "timings", "total"}.

    Returns
    -------
    str
        The section's HTML.
    """
    rows = [[k, v] for k, v in info["settings"].items()]
    timings = [[k, v] for k, v in info["timings"].items()] + [["total", info["total"]]]
    return section(
        "reproduce",
        "Reproducing this report",
        f"<p>Command: <code>{esc(info['command'])}</code> at commit "
        f"<code>{esc(info.get('commit') or 'unknown')}</code> (uncommitted changes are not "
        "recorded).</p>",
        table("Settings", ("setting", "value"), rows),
        table("Versions", ("package", "version"), info["versions"].items()),
        table("Machine", ("what", "value"), info["machine"].items()),
        table("Stage timings (s)", ("stage", "seconds"), timings),
    )


def section_leaderboards(result: dict) -> str:
    """Build the section of the committed leaderboards.

    Per task, ours beside the methods from outside, from the result files named under each.

    Parameters
    ----------
    result : dict
        The result of `scripts.report.stages.stage_leaderboards`.

    Returns
    -------
    str
        The section's HTML.
    """
    if not result["boards"]:
        return section("leaderboards", "Leaderboards", f"<p>{esc(result['missing'])}</p>")
    parts = [
        "<p>Read from the committed result files, not run here: each ran through its frozen "
        "protocol (docs/guides/benchmark-your-method.md, docs/guides/benchmark-your-policy.md); "
        "<code>topomap leaderboard FILE...</code> ranks any set of them.</p>"
    ]
    for board in result["boards"]:
        parts.append(f"<h3>{esc(board['heading'])}</h3>")
        parts += [table(heading, header, rows) for heading, header, rows in board["tables"]]
        files = ", ".join(f"<code>{esc(f)}</code>" for f in board["files"])
        parts.append(f"<p>Files: {files}</p>")
    return section("leaderboards", "Leaderboards: ours beside methods from outside", *parts)
