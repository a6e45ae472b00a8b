"""Rank result files per task and protocol, with intervals and paired tests.

Files are grouped into boards by (task, protocol name and version, split, metric) and, inside a
board, by each record's ``group`` (a condition, a world, a pose variant). Each method's value
is the mean over its units with a 95 % interval: bootstrap (percentile, ``scipy.stats.bootstrap``)
for errors and scores, Wilson (``scipy.stats.binomtest``) for rates. Against the ``reference``
method the comparison is paired on the units both have a value for: the mean difference with
its bootstrap interval over the shared units, with the Wilcoxon signed-rank test for errors
and scores, the exact McNemar test (a binomial test on the discordant units) for rates. A
failed unit counts in ``failed`` and in no mean or test.

Files of the same protocol name but another version are refused, never mixed; files of one
method (same name, spec and parameters) are joined, so that seeds or logs run apart rank
together.
"""

from __future__ import annotations

import html
import os
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np
from scipy import stats

from common.fileio import UnreadableJSON, read_json
from scripts.leaderboard.files import FORMAT, KINDS, MAX_BYTES, ResultFileError, read_result

__all__ = ["Row", "leaderboard_html", "leaderboard_markdown", "load_results", "rank"]

BOOTSTRAP_SEED = 0
N_RESAMPLES = 4000
MIN_SEEDS = 5  # fewer units: the leaderboard warns that the bootstrap interval is too narrow
MIN_EPISODES = 20  # fewer episodes of a rate: it warns that the interval is rough


def load_results(paths) -> list[dict]:
    """Read the result files among ``paths``.

    A file is read and checked (refused with
    [`ResultFileError`][scripts.leaderboard.files.ResultFileError] when it is no result file); a
    folder contributes the ``*.json`` files directly in it whose ``format`` is a result file's
    (other JSON there, such as a protocol's cells, is passed over).

    Parameters
    ----------
    paths : iterable of str or os.PathLike
        Result files and folders.

    Returns
    -------
    list of dict
        The checked result files, each with its path under ``_path``.

    Raises
    ------
    ValueError
        When ``paths`` hold no result file.
    """
    results = []
    for given in paths:
        given = Path(given)
        if given.is_dir():
            for path in sorted(given.glob("*.json")):
                if _looks_like_result(path):
                    results.append({**read_result(path), "_path": str(path)})
        else:
            results.append({**read_result(given), "_path": str(given)})
    if not results:
        raise ValueError(f"no result files in {[str(p) for p in paths]}")
    return results


def _looks_like_result(path: Path) -> bool:
    if not path.is_file() or path.stat().st_size > MAX_BYTES:
        return True  # let the reader refuse it by name (a pipe or device must not be opened)
    try:
        data = read_json(path)
    except UnreadableJSON:
        return False
    return isinstance(data, dict) and data.get("format") == FORMAT


def method_label(method: dict) -> str:
    """Label a method by its ``name`` with the parameters the user chose.

    Those the protocol chose, such as the manifold protocol's ``n_clusters``, are left out.

    Parameters
    ----------
    method : dict
        A result file's ``method`` block.

    Returns
    -------
    str
        ``name(k=v, ...)``, or ``name`` alone when the user chose no parameter.
    """
    chosen = method.get("protocol_params", ["n_clusters"])
    chosen = chosen if isinstance(chosen, list) else []
    params = {k: v for k, v in method.get("params", {}).items() if k not in chosen}
    inner = ", ".join(f"{k}={v!r}" for k, v in sorted(params.items()))
    return f"{method['name']}({inner})" if inner else method["name"]


@dataclass
class Row:
    """One method in one group of a board.

    Parameters
    ----------
    method : str
        The method's label.
    notes : str
        The method's notes.
    values : dict
        Unit -> value (failed units left out).
    failed : int
        The number of failed units.
    mean : float, default nan
        The mean over ``values``.
    lo, hi : float, default nan
        The 95 % interval of the mean.
    paired : dict
        The paired comparison with the reference method: ``n`` shared units, ``diff`` with
        its interval ``lo``, ``hi``, ``p`` and ``test``; empty for the reference itself or
        without one.
    """

    method: str
    notes: str
    values: dict  # unit -> value (failed units left out)
    failed: int
    mean: float = float("nan")
    lo: float = float("nan")
    hi: float = float("nan")
    paired: dict = field(default_factory=dict)


def rank(results: list[dict], reference: str | None = None) -> dict:
    """Rank the methods of ``results`` per board and group, best first.

    Parameters
    ----------
    results : list of dict
        Result files as [`load_results`][scripts.leaderboard.ranking.load_results] gives them.
    reference : str or None, default None
        A method (its label, name or spec) every other is compared with, paired.

    Returns
    -------
    dict
        ``{(task, protocol, version, split, metric, kind): {group: [Row, ...] best first}}``.

    Raises
    ------
    ValueError
        When ``reference`` names no method or several, or when two files share a protocol
        name but not its version.
    """
    _check_versions(results)
    joined = _join(results)
    if reference is not None:
        _check_reference(joined, reference)
    boards: dict = {}
    rng = np.random.default_rng(BOOTSTRAP_SEED)
    for (board, label), (_identity, notes, records) in joined.items():
        for r in records:
            rows = boards.setdefault(board, {}).setdefault(r["group"], {})
            row = rows.setdefault(label, Row(label, notes, {}, 0))
            if r["failure"] is None:
                row.values[r["unit"]] = r["value"]
            else:
                row.failed += 1
    kind_of = {board: board[5] for board in boards}
    out = {}
    for board, groups in boards.items():
        kind = kind_of[board]
        out[board] = {}
        for group, rows in sorted(groups.items()):
            for row in rows.values():
                _summarise(row, kind, rng)
            ref = _find(rows, reference, joined, board) if reference else None
            for row in rows.values():
                if ref is not None and row is not ref:
                    row.paired = _paired(row, ref, kind, rng)
            better = KINDS[kind]
            out[board][group] = sorted(
                rows.values(),
                key=lambda r: (np.isnan(r.mean), -r.mean if better else r.mean, r.method),
            )
    return out


def _check_versions(results):
    seen = {}
    for r in results:
        key = (r["task"], r["protocol"]["name"])
        version = r["protocol"]["version"]
        if key in seen and seen[key][0] != version:
            raise ValueError(
                f"{r['_path']} is protocol {key[1]!r} version {version}, {seen[key][1]} is "
                f"version {seen[key][0]}: results of different protocol versions are not "
                "comparable; rerun the older method under the current protocol"
            )
        seen.setdefault(key, (version, r["_path"]))


def _join(results) -> dict:
    joined = {}
    for r in results:
        p, m = r["protocol"], r["metric"]
        board = (r["task"], p["name"], p["version"], r["split"], m["name"], m["kind"])
        label = method_label(r["method"])
        identity = (r["method"].get("spec"), repr(sorted(r["method"].get("params", {}).items())))
        key = (board, label)
        if key in joined:
            if joined[key][0] != identity:
                raise ValueError(f"{r['_path']}: another method is also labelled {label!r}")
            units = {(x["group"], x["unit"]) for x in joined[key][2]}
            twice = [x for x in r["records"] if (x["group"], x["unit"]) in units]
            if twice:
                raise ResultFileError(
                    r["_path"],
                    "records",
                    f"{label} already has {twice[0]['group']} {twice[0]['unit']} from another file",
                )
            joined[key][2].extend(r["records"])
        else:
            joined[key] = [identity, _method_notes(r["method"]), list(r["records"])]
    return {k: (v[0], v[1], v[2]) for k, v in joined.items()}


def _method_notes(method: dict) -> str:
    """Join the notes a method's file gives, its source's digest, and a sandbox warning.

    The warning is given where an outside policy's process ran without a sandbox (it could
    read the datasets on disk).
    """
    notes = [method.get("notes") or ""]
    source = method.get("source")
    if isinstance(source, dict) and isinstance(source.get("sha256"), str):
        notes.append(f"source {source['sha256'][:12]}")
    if method.get("sandboxed") is False and ":" in str(method.get("spec", "")).replace(
        "servo.task.POLICIES:", ""
    ):
        notes.append("NOT sandboxed: the policy's process could read the disk")
    return "; ".join(n for n in notes if n)


def _warnings(row: Row, kind: str) -> list[str]:
    """List what a reader must know before trusting a row's interval and its paired test."""
    out, n = [], len(row.values)
    if kind == "rate" and 0 < n < MIN_EPISODES:
        out.append(f"only {n} episodes (fewer than {MIN_EPISODES}): a rough interval")
    elif kind != "rate" and 0 < n < MIN_SEEDS:
        out.append(
            f"only {n} units (fewer than {MIN_SEEDS}): the bootstrap interval is no "
            f"wider than the spread of {n} values, too narrow"
        )
    q = row.paired
    if q.get("n") and not np.isnan(q["lo"]):
        excludes = q["lo"] > 0 or q["hi"] < 0
        if excludes != (q["p"] < 0.05):
            out.append(
                f"interval and test disagree over {q['n']} units: a percentile "
                "bootstrap of few units is too narrow; the test decides"
            )
    return out


def _matches(label: str, method_key, reference: str) -> bool:
    name = label.split("(")[0]
    return reference in (label, name, method_key[0])


def _check_reference(joined, reference):
    labels = {label for (_, label), v in joined.items() if _matches(label, v[0], reference)}
    if not labels:
        known = sorted({label for _, label in joined})
        raise ValueError(f"--reference {reference!r} names no method; the methods are {known}")
    if len(labels) > 1:
        raise ValueError(
            f"--reference {reference!r} names several methods: {sorted(labels)}; "
            "give the full label"
        )


def _find(rows, reference, joined, board):
    for label, row in rows.items():
        if _matches(label, joined[(board, label)][0], reference):
            return row
    return None


def _summarise(row: Row, kind: str, rng) -> None:
    x = np.array(list(row.values.values()), dtype=float)
    if x.size == 0:
        return
    row.mean = float(x.mean())
    if kind == "rate":
        ci = stats.binomtest(int(x.sum()), x.size).proportion_ci(method="wilson")
        row.lo, row.hi = float(ci.low), float(ci.high)
    else:
        row.lo, row.hi = _bootstrap(x, rng)


def _bootstrap(x: np.ndarray, rng) -> tuple[float, float]:
    if x.size < 2 or np.ptp(x) == 0:
        return float(x.mean()), float(x.mean())
    res = stats.bootstrap(
        (x,), np.mean, n_resamples=N_RESAMPLES, method="percentile", random_state=rng
    )
    return float(res.confidence_interval.low), float(res.confidence_interval.high)


def _paired(row: Row, ref: Row, kind: str, rng) -> dict:
    units = sorted(set(row.values) & set(ref.values))
    if not units:
        return {"n": 0}
    a = np.array([row.values[u] for u in units], dtype=float)
    b = np.array([ref.values[u] for u in units], dtype=float)
    d = a - b
    if kind == "rate":
        wins, losses = int(np.sum(d > 0)), int(np.sum(d < 0))
        p = stats.binomtest(min(wins, losses), wins + losses).pvalue if wins + losses else 1.0
        test = f"McNemar exact ({wins} better, {losses} worse)"
    else:
        p = float(stats.wilcoxon(d).pvalue) if np.any(d != 0) and d.size > 1 else 1.0
        test = "Wilcoxon signed-rank"
    lo, hi = _bootstrap(d, rng)  # over the shared units, for rates too (differences of 0/1)
    return {
        "n": len(units),
        "diff": float(d.mean()),
        "lo": lo,
        "hi": hi,
        "p": float(p),
        "test": test,
    }


def _fmt(value: float, kind: str) -> str:
    return "--" if np.isnan(value) else f"{100 * value:.1f}%" if kind != "score" else f"{value:.3f}"


def leaderboard_tables(boards: dict, reference: str | None):
    """Yield the tables the markdown and HTML forms show, one per board and group.

    Parameters
    ----------
    boards : dict
        The boards of [`rank`][scripts.leaderboard.ranking.rank].
    reference : str or None
        The reference method the boards were ranked with, or None.

    Yields
    ------
    heading : str
        The board and group, the metric and which way is better.
    header : list of str
        The column headings.
    body : list of list of str
        The rows of cells, best method first.
    """
    for (task, protocol, version, split, metric, kind), groups in boards.items():
        for group, rows in groups.items():
            heading = f"{task}: {protocol} v{version}, split {split}, {group} ({metric}, " + (
                "lower is better)" if not KINDS[kind] else "higher is better)"
            )
            ci = "Wilson" if kind == "rate" else "bootstrap"
            header = ["rank", "method", "n", "failed", f"{metric}: mean [95% {ci} CI]"]
            if reference:
                header += [f"paired vs {reference}: difference [95% CI]", "p (test)"]
            header.append("notes")
            body = []
            for i, r in enumerate(rows, 1):
                interval = f"{_fmt(r.mean, kind)} [{_fmt(r.lo, kind)}, {_fmt(r.hi, kind)}]"
                cells = [str(i), r.method, str(len(r.values)), str(r.failed), interval]
                if reference:
                    q = r.paired
                    if not q:
                        cells += ["reference" if r.values or r.failed else "--", ""]
                    elif q["n"] == 0:
                        cells += ["no shared units", ""]
                    else:
                        diff = _fmt(q["diff"], kind)
                        ci_text = (
                            ""
                            if np.isnan(q["lo"])
                            else (f" [{_fmt(q['lo'], kind)}, {_fmt(q['hi'], kind)}]")
                        )
                        cells += [f"{diff}{ci_text} over {q['n']}", f"{q['p']:.3g} ({q['test']})"]
                cells.append("; ".join(filter(None, [r.notes, *_warnings(r, kind)])))
                body.append(cells)
            yield heading, header, body


def leaderboard_markdown(results: list[dict], reference: str | None = None) -> str:
    """Render the ranking of [`rank`][scripts.leaderboard.ranking.rank] as markdown.

    A heading and a table per board and group.

    Parameters
    ----------
    results : list of dict
        Result files as [`load_results`][scripts.leaderboard.ranking.load_results] gives them.
    reference : str or None, default None
        A method every other is compared with, paired.

    Returns
    -------
    str
        The markdown.
    """
    boards = rank(results, reference)
    parts = []
    for heading, header, body in leaderboard_tables(boards, reference):
        lines = [f"### {heading}", "", "| " + " | ".join(header) + " |", "|" + "---|" * len(header)]
        lines += ["| " + " | ".join(c.replace("|", "\\|") for c in row) + " |" for row in body]
        parts.append("\n".join(lines))
    return "\n\n".join(parts) + "\n"


def leaderboard_html(results: list[dict], reference: str | None = None) -> str:
    """Render the same ranking as a standalone HTML page.

    Parameters
    ----------
    results : list of dict
        Result files as [`load_results`][scripts.leaderboard.ranking.load_results] gives them.
    reference : str or None, default None
        A method every other is compared with, paired.

    Returns
    -------
    str
        The HTML page.
    """
    boards = rank(results, reference)
    out = [
        "<!doctype html><html><head><meta charset='utf-8'><title>leaderboard</title>",
        "<style>table{border-collapse:collapse}td,th{border:1px solid #ccc;padding:2px 6px}"
        "</style></head><body><h1>Leaderboard</h1>",
    ]
    for heading, header, body in leaderboard_tables(boards, reference):
        out.append(f"<h2>{html.escape(heading)}</h2><table><tr>")
        out += [f"<th>{html.escape(h)}</th>" for h in header]
        out.append("</tr>")
        for row in body:
            out.append("<tr>" + "".join(f"<td>{html.escape(c)}</td>" for c in row) + "</tr>")
        out.append("</table>")
    out.append("</body></html>")
    return "\n".join(out) + "\n"


def run(args) -> int:
    """Run ``topomap leaderboard PATH ... [--reference NAME] [--html FILE] [--markdown FILE]``.

    Parameters
    ----------
    args : argparse.Namespace
        ``paths``, ``reference``, ``markdown`` and ``html``.

    Returns
    -------
    int
        The exit status, 0.
    """
    from common.fileio import atomic_write_bytes

    results = load_results(args.paths)
    text = leaderboard_markdown(results, args.reference)
    print(text, end="")
    for path, content in (
        (args.markdown, text),
        (args.html, args.html and leaderboard_html(results, args.reference)),
    ):
        if path:
            os.makedirs(Path(path).parent, exist_ok=True)
            atomic_write_bytes(path, content.encode())
            print(f"wrote {path}")
    return 0


def add_parser(sub, help_text: str):
    """Register ``leaderboard`` on the subparsers action ``sub``.

    Parameters
    ----------
    sub : argparse._SubParsersAction
        The subparsers action.
    help_text : str
        The command's help line.

    Returns
    -------
    argparse.ArgumentParser
        The new parser.
    """
    p = sub.add_parser("leaderboard", help=help_text, description=__doc__.splitlines()[0])
    p.add_argument(
        "paths",
        nargs="+",
        metavar="PATH",
        help="result files, or folders whose result files (*.json) are read",
    )
    p.add_argument(
        "--reference",
        default=None,
        help="the method the others are compared with, paired (name, label or spec)",
    )
    p.add_argument("--markdown", default=None, help="also write the markdown here")
    p.add_argument("--html", default=None, help="also write an HTML page here")
    p.set_defaults(func=run)
    return p
