"""README's Results table and the results pages, written from the committed result files.

``python -m scripts.results`` rewrites README.md between its markers (the results table, and
the held-out worlds' tables), the results table of the docs' front page (``docs/index.md``)
and ``docs/results/{manifold-clustering,observation-grouping,servo,held-out-worlds}.md``;
``--check`` writes
nothing and exits 1 when any of them differs from what the files give (run by the tests, so
a number edited by hand, or a result file changed without regenerating, is caught).
"""

from __future__ import annotations

import argparse
import sys
from collections.abc import Callable
from pathlib import Path

from common.fileio import read_json
from scripts.results.heldout import HELDOUT_SOURCE, heldout_summary, heldout_worlds
from scripts.results.rows import PAGES, ROWS, SECTIONS, Row, Section
from scripts.results.sources import Estimate, provenance, read_estimate, servo_results
from scripts.tables import Column, Table

__all__ = ["RENDERERS", "generate", "main", "readme_table"]

REPO_ROOT = Path(__file__).resolve().parents[2]
START, END = "<!-- results:start -->", "<!-- results:end -->"
HELDOUT_START, HELDOUT_END = "<!-- heldout:start -->", "<!-- heldout:end -->"
COMMAND = "python -m scripts.results"
DATA = Path("docs") / "results" / "data"
PAGES_DIR = Path("docs") / "results"
FRONT_PAGE = Path("docs") / "index.md"
_BANNER = (
    f"<!-- written by `{COMMAND}` from the files under docs/results/data/; "
    "edit those (and their meta.json), then run it again -->"
)


def _number(measure: str, x: float) -> str:
    if measure.startswith("groups"):
        return f"{x:.0f}"
    if measure == "purity":
        return f"{x:.3f}"
    return f"{100 * x:.1f}%"


def _estimate_text(row: Row, e: Estimate) -> str:
    if e.interval is None:
        return _number(row.measure, e.value)
    lo, hi = (_number(row.measure, v) for v in e.interval)
    return f"{_number(row.measure, e.value)} [{lo}, {hi}]"


def readme_table(root: Path, pages: Path = PAGES_DIR) -> Table:
    """Tabulate one row per `ROWS` entry: the estimate with its 95% interval and what it rests on.

    Parameters
    ----------
    root : Path
        The repository.
    pages : Path, default PAGES_DIR
        The results pages' folder as the page holding the table links it: README's
        ``docs/results``, the docs front page's ``results``.

    Returns
    -------
    Table
        The results table.
    """
    rows = []
    for row in ROWS:
        e = read_estimate(root / DATA, row.reader, row.source, **row.keys)
        title, page = PAGES[row.task]
        rows.append(
            {
                "task": f"[{title}]({(pages / page).as_posix()})",
                "data": row.data,
                "method": row.method,
                "measure": row.measure,
                "estimate": _estimate_text(row, e),
                "n": f"{e.n} {e.unit[:-1] if e.n == 1 and e.unit.endswith('s') else e.unit}",
                "split": row.split,
            }
        )
    columns = (
        Column("task", "task"),
        Column("data", "data"),
        Column("method", "method"),
        Column("measure", "measure"),
        Column("estimate", "estimate [95% interval]"),
        Column("n", "n"),
        Column("split", "measured on"),
    )
    notes = (
        "Intervals: Wilson for success rates, bootstrap over seeds for errors and purity; "
        "a real log has no ground truth, so its groups are counted, not scored. "
        f"Written by `{COMMAND}` from `docs/results/data/`; each task's link shows every "
        "table with the command, commit, machine and date that made it.",
    )
    return Table.of(columns, rows, notes=notes)


# --------------------------------------------------------------------------- pages


def _protocol_summary(root: Path, sources) -> str:
    from scripts.manifold import load_cells, protocol_markdown, summarize

    legend = (
        "Conditions (`scripts/manifold/protocol.py`): `interleaved`, even frames of each drive "
        "build the map and odd frames test it; `held-out`, the test frames come from seed S+1's "
        "drives; `randomized`, worlds collected with `--randomize`; `hard`, with `--appearance "
        "hard` (every branch in the main manifold's materials). Seed 0 is the dev seed the "
        "settings were chosen on, shown beside and left out of the means; K = 8, Q = 35."
    )
    table = protocol_markdown(summarize(load_cells(root / DATA / sources[0])))
    return f"{table}\n\n{legend}\n"


def _grouping_tables(root: Path, sources) -> str:
    from scripts.grouping import comparison_table, grouping_table

    result = read_json(root / DATA / sources[0])
    return "\n".join(t.to_markdown() for t in (grouping_table(result), comparison_table(result)))


def _grouping_seeds(root: Path, sources) -> str:
    """Tabulate the scan grouping's scores on every dataset seed, per world and pose source."""
    files = sorted(
        (root / DATA / sources[0]).parent.glob(Path(sources[0]).name),
        key=lambda f: int(f.stem.rsplit("-", 1)[1]),
    )
    results = [read_json(f) for f in files]
    rows = []
    for world in results[0]["default"]:
        for variant, first in results[0]["default"][world].items():
            if not isinstance(first, dict):
                continue
            scores = [r["default"][world][variant] for r in results]
            row = {"world": world, "poses": variant, "seeds": len(scores)}
            for key in ("purity", "ari"):
                e = read_estimate(
                    root / DATA,
                    "grouping-score",
                    sources[0],
                    world=world,
                    variant=variant,
                    score=key,
                )
                row[key] = e
            row["groups"] = [s["groups"] for s in scores]
            row["met"] = sum(bool(s["meets_targets"]) for s in scores)
            rows.append(row)

    def interval(e: Estimate) -> str:
        return (
            f"{e.value:.3f} [{e.interval[0]:.3f}, {e.interval[1]:.3f}]"
            if e.interval
            else (f"{e.value:.3f}")
        )

    columns = (
        Column("world", "world"),
        Column("poses", "poses"),
        Column("seeds", "dataset seeds", "d"),
        Column("purity", "purity: mean [95% CI]", interval),
        Column("ari", "ARI: mean [95% CI]", interval),
        Column("groups", "groups per seed", lambda g: ", ".join(map(str, g))),
        Column("met", "seeds meeting the targets", "d"),
    )
    return Table.of(columns, rows).to_markdown()


def _carmen_table(root: Path, sources) -> str:
    from scripts.grouping import carmen_report

    return carmen_report(read_json(root / DATA / sources[0])) + "\n"


def _servo_summary(root: Path, sources) -> str:
    from scripts.servo_tables import summary_table

    results = [e for s in sources for e in servo_results(root / DATA / s)]
    results.sort(key=lambda e: (e["world"], e["tier"] != "view", bool(e.get("randomize"))))
    return summary_table(results).to_markdown()


def _servo_reruns(root: Path, sources) -> str:
    """Compare each rerun's episodes with the committed cell of its controller.

    The same episodes are paired (``servo.task.compare``): whether the current code ends them
    as the committed run did.
    """
    from servo.task import compare

    committed = dict.fromkeys(row.source for row in ROWS if row.reader == "servo-success")
    cells = [e for s in committed for e in servo_results(root / DATA / s)]
    rows = []
    for path in sorted((root / DATA / sources[0]).glob("*ep.json")):
        for rerun in servo_results(path):
            same_policy = [e for e in cells if e["policy"] == rerun["policy"]]
            for c in compare(same_policy, [rerun]):
                ends = {e["episode"]: (e["success"], e["reason"]) for e in rerun["episodes_detail"]}
                base = next(
                    e
                    for e in same_policy
                    if e["world"] == rerun["world"]
                    and e["tier"] == rerun["tier"]
                    and e["randomize"] == rerun["randomize"]
                )
                same = sum(
                    ends.get(e["episode"]) == (e["success"], e["reason"])
                    for e in base["episodes_detail"]
                )
                rows.append(
                    {
                        "world": rerun["world"],
                        "policy": rerun["policy"],
                        "cell": f"{rerun['tier']}/{rerun['split']}"
                        + ("/randomize" if rerun["randomize"] else ""),
                        "n": c.n,
                        "committed": c.successes_a,
                        "rerun": c.successes_b,
                        "changed": f"+{c.gained} / -{c.lost}",
                        "same_end": same,
                    }
                )
    columns = (
        Column("world", "world"),
        Column("policy", "policy"),
        Column("cell", "starts / split"),
        Column("n", "first episodes rerun", "d"),
        Column("committed", "successes, committed run", "d"),
        Column("rerun", "successes, rerun", "d"),
        Column("changed", "gained / lost by the rerun"),
        Column("same_end", "same end (success, reason)", "d"),
    )
    note = (
        "`topomap servo-compare COMMITTED RERUN` pairs a rerun with its committed cell "
        "episode by episode.",
    )
    return Table.of(columns, rows, notes=note).to_markdown()


def leaderboard_inputs(root: Path, sources) -> tuple[list[dict], str | None]:
    """Load the result files of a leaderboard section and name its reference method.

    The files in a folder are paired against the method its ``meta.json`` names as
    ``reference``; the files ``sources`` names, against the first file's method.

    Parameters
    ----------
    root : Path
        The repository.
    sources : sequence of str
        The section's sources under ``docs/results/data/``: one folder, or files.

    Returns
    -------
    tuple of (list of dict, str or None)
        The results and the reference method's name.
    """
    from scripts.leaderboard import load_results

    paths = [root / DATA / source for source in sources]
    if paths[0].is_dir():
        reference = read_json(paths[0] / "meta.json").get("reference")
        return load_results(paths[:1]), reference
    results = load_results(paths)
    return results, results[0]["method"]["name"]


def _leaderboard(root: Path, sources) -> str:
    """Rank a section's result files (`leaderboard_inputs`) as ``topomap leaderboard`` does."""
    from scripts.leaderboard import leaderboard_markdown

    results, reference = leaderboard_inputs(root, sources)
    return leaderboard_markdown(results, reference=reference)


RENDERERS: dict[str, Callable[[Path, tuple[str, ...]], str]] = {
    "leaderboard": _leaderboard,
    "servo-reruns": _servo_reruns,
    "protocol-summary": _protocol_summary,
    "grouping-tables": _grouping_tables,
    "grouping-seeds": _grouping_seeds,
    "carmen-table": _carmen_table,
    "servo-summary": _servo_summary,
    "heldout-summary": lambda root, sources: heldout_summary(root / DATA, sources),
    "heldout-worlds": lambda root, sources: heldout_worlds(root / DATA, sources),
}
_MADE = ("command", "commit", "machine", "date")


def _made_by(root: Path, source: str) -> str:
    """List how a file was made, from its meta.json entry: every key, the four named first."""
    meta = provenance(root / DATA, source)
    missing = [k for k in _MADE if k not in meta]
    if missing:
        raise ValueError(f"{source}: its meta.json entry lacks {missing}")
    keys = [*_MADE, *sorted(k for k in meta if k not in _MADE)]
    lines = [f"- file: `{(DATA / source).as_posix()}`"]
    lines += [f"  - {k}: " + (f"`{meta[k]}`" if k == "command" else meta[k]) for k in keys]
    return "\n".join(lines)


def _section(root: Path, section: Section) -> str:
    made = "\n".join(_made_by(root, s) for s in section.sources)
    body = RENDERERS[section.renderer](root, section.sources)
    return f"## {section.heading}\n\n{body}\nMade by:\n\n{made}\n"


def page(root: Path, task: str) -> str:
    """Write the results page of ``task``: its rows of the README table, then its full tables.

    Parameters
    ----------
    root : Path
        The repository.
    task : str
        A key of `PAGES`.

    Returns
    -------
    str
        The page's markdown.
    """
    title, _ = PAGES[task]
    table = readme_table(root)
    own = [r for r, row in zip(table.rows, ROWS, strict=True) if row.task == task]
    sections = "\n".join(_section(root, s) for s in SECTIONS if s.task == task)
    if not own:  # the held-out worlds: their own tables, also in README
        lead = "The current numbers, from the committed result file (README shows the first table)."
        return f"{_BANNER}\n\n# Results: {title.lower()}\n\n{lead}\n\n{sections}"
    summary = Table.of(table.columns[1:], own).to_markdown()
    return (
        f"{_BANNER}\n\n# Results: {title.lower()}\n\n"
        f"The current numbers, from the committed result files (the same rows as the Results "
        f"table of the repository's README).\n\n{summary}\n{sections}"
    )


def _between(text: str, start: str, end: str, body: str, where: Path) -> str:
    """Replace what lies between the one ``start`` and one ``end`` marker of ``text``."""
    if text.count(start) != 1 or text.count(end) != 1 or text.index(start) > text.index(end):
        raise ValueError(f"{where}: needs one {start} before one {end}")
    head, rest = text.split(start)
    _, tail = rest.split(end)
    return f"{head}{start}\n{body}{end}{tail}"


def generate(root: Path) -> dict[Path, str]:
    """Generate every file (relative path -> text) for the repository at ``root``.

    Parameters
    ----------
    root : Path
        The repository.

    Returns
    -------
    dict of Path to str
        The text of each generated file, by path relative to ``root``.
    """
    readme_path = root / "README.md"
    readme = readme_path.read_text(encoding="utf-8")
    readme = _between(readme, START, END, readme_table(root).to_markdown(), readme_path)
    held = heldout_summary(root / DATA, (HELDOUT_SOURCE,))
    files = {Path("README.md"): _between(readme, HELDOUT_START, HELDOUT_END, held, readme_path)}
    # the docs' front page: the same table, its links relative to docs/
    front_path = root / FRONT_PAGE
    front = front_path.read_text(encoding="utf-8")
    table = readme_table(root, PAGES_DIR.relative_to("docs")).to_markdown()
    files[FRONT_PAGE] = _between(front, START, END, table, front_path)
    for task, (_, name) in PAGES.items():
        files[PAGES_DIR / name] = page(root, task)
    return files


def main(argv: list[str] | None = None) -> int:
    """Write (or with ``--check``, check) README's Results table and the results pages.

    Parameters
    ----------
    argv : list of str or None, default None
        The arguments; None reads ``sys.argv[1:]``.

    Returns
    -------
    int
        The exit status: 0, or 1 when ``--check`` finds a file out of date.
    """
    parser = argparse.ArgumentParser(
        prog=COMMAND,
        description="README's Results table and docs/results/*.md, from the "
        "committed result files under docs/results/data/.",
    )
    parser.add_argument(
        "--check",
        action="store_true",
        help="write nothing; exit 1 if a generated file is out of date",
    )
    parser.add_argument("--root", type=Path, default=REPO_ROOT, help="the repository")
    args = parser.parse_args(argv)
    stale = []
    for rel, text in generate(args.root).items():
        path = args.root / rel
        if path.exists() and path.read_text(encoding="utf-8") == text:
            continue
        stale.append(rel.as_posix())
        if not args.check:
            path.write_text(text, encoding="utf-8")
    if args.check and stale:
        print(f"out of date (run {COMMAND}): {', '.join(stale)}", file=sys.stderr)
        return 1
    print(
        ("checked" if args.check else "wrote") + f": README.md, {FRONT_PAGE.as_posix()} and "
        f"{len(PAGES)} results pages"
        + (f" ({len(stale)} changed)" if stale and not args.check else "")
    )
    return 0
