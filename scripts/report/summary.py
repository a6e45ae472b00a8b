"""The report's opening summary, built from the results the stages already computed.

One line per task with its headline number, that number's 95% interval and whether it meets its
target.

Where a task is measured on several worlds, the line shows the worst world: each target holds
per world (docs/guides/servo.md, docs/guides/observation-grouping.md), so the worst one
decides. A task without a stated target says so (``target`` None) rather than being given one
here.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence

__all__ = ["MANIFOLD_HEADLINE", "POLICY_NAMES", "summarise_run"]

# The manifold clustering's headline cell of the frozen protocol: the paper's interleaved
# split, the protocol's features (HSV histograms), the method itself.
MANIFOLD_HEADLINE = ("interleaved", "hsv", "ours")
POLICY_NAMES = {
    "servo": "ManifoldServo (laser and images)",
    "signal": "SignalServo (camera only)",
    "oracle": "oracle (true pose; the upper bound)",
    "greedy": "greedy F probing",
    "greedy-target": "greedy F probing toward the target",
    "random": "random commands",
}


def summarise_run(results: Mapping[str, dict]) -> list[dict]:
    """Build the summary lines of a run from its stages' results.

    The results are by stage name; a stage that did not run gives no line.

    Parameters
    ----------
    results : mapping
        ``seeds`` (``stage_protocol``), ``manifold`` (``scripts.manifold.reproduce``),
        ``grouping`` (``scripts.grouping.evaluate_grouping``) and ``servo`` (``stage_servo``:
        ``{"results": [run_protocol results], ...}``), each optional.

    Returns
    -------
    list of dict
        One per task: ``task``, ``measure`` (what the number is), ``value`` (None: not
        scored), ``interval`` (``[lo, hi]``, None where the run has none) and ``interval_kind``,
        ``target`` (text, None: no target), ``meets`` (bool, None without a target or a
        value) and ``detail`` (per world or seed).
    """
    lines = []
    if "manifold" in results or "seeds" in results:
        lines.append(_manifold_line(results.get("seeds"), results.get("manifold")))
    if "grouping" in results:
        lines.append(_grouping_line(results["grouping"]))
    if "servo" in results:
        lines += _servo_lines(results["servo"]["results"])
    return lines


def _line(
    task, measure, value, interval=None, interval_kind=None, target=None, meets=None, detail=""
) -> dict:
    return {
        "task": task,
        "measure": measure,
        "value": value,
        "interval": interval,
        "interval_kind": interval_kind,
        "target": target,
        "meets": meets,
        "detail": detail,
    }


def _manifold_line(seeds: dict | None, manifold: dict | None) -> dict:
    """Build the manifold clustering's line from the frozen protocol or this run's dataset.

    It gives the frozen protocol's mean test error over fresh dataset seeds when the run shows
    it, else this run's own dataset seed (one number, no interval).
    """
    task = "manifold clustering (Grudic & Mulligan)"
    own = _own_test_error(manifold)
    own_text = "" if own is None else f"this run's dataset: test error {own:.3f}"
    for r in (seeds or {}).get("rows", []):
        if (r["condition"], r["features"], r["method"]) == MANIFOLD_HEADLINE and r["summary"]:
            s = r["summary"]
            detail = f"dev seed 0: {r['dev_error']:.3f}" if r["dev_error"] is not None else ""
            detail = "; ".join(t for t in (detail, own_text) if t)
            return _line(
                task,
                f"test error, mean over {s['n']} fresh dataset seeds (interleaved split, HSV "
                f"histograms; {seeds['source']})",
                s["mean"],
                [s["lo"], s["hi"]],
                "bootstrap 95%",
                detail=detail,
            )
    return _line(
        task,
        "test error on this run's dataset (interleaved split, HSV histograms; one dataset "
        "seed, no interval)",
        own,
    )


def _own_test_error(manifold: dict | None) -> float | None:
    if not manifold:
        return None
    from scripts.manifold import FEATURES  # the protocol's names of its feature sets

    hsv = FEATURES[MANIFOLD_HEADLINE[1]][0]
    return next(
        (
            r["test_error"]
            for r in manifold.get("real", [])
            if r["features"] == hsv and r["method"] == MANIFOLD_HEADLINE[2]
        ),
        None,
    )


def _grouping_line(grouping: dict) -> dict:
    """Build the grouping's line: the lowest purity over the worlds.

    The purity is that of the pose source the report draws (odometry and ICP when run); the
    target is purity and groups per manifold in every world.
    """
    settings = grouping["settings"]
    targets, shown = settings["targets"], settings["shown"]
    scores = {w: entry[shown] for w, entry in grouping["default"].items()}
    target = (
        f"purity >= {targets['purity_min']:g} and <= {targets['max_groups_per_manifold']} "
        "groups per manifold, in every world"
    )
    measure = f"purity of the groups, lowest world ({shown} poses; one grouping per world)"
    if not scores or any(s["purity"] is None for s in scores.values()):
        return _line(
            "observation grouping (Blanco et al.)",
            measure,
            None,
            target=target,
            detail="no ground-truth labels: not scored",
        )
    worst = min(scores, key=lambda w: scores[w]["purity"])
    detail = "; ".join(
        f"{w}: purity {s['purity']:.3f}, at most {s['max_groups_per_manifold']} groups per "
        f"manifold ({'meets' if s['meets_targets'] else 'misses'})"
        for w, s in scores.items()
    )
    return _line(
        "observation grouping (Blanco et al.)",
        measure,
        scores[worst]["purity"],
        target=target,
        meets=all(s["meets_targets"] for s in scores.values()),
        detail=detail,
    )


def _servo_lines(results: Sequence[dict]) -> list[dict]:
    """Build one line per policy and start condition.

    Each gives the lowest world's success rate with its Wilson 95% interval, against the
    policy's target for that condition.
    """
    from servo.task import SUCCESS_TARGETS

    cells: dict[tuple, list[dict]] = {}
    for r in results:
        key = (r["policy"], r.get("tier"), bool(r.get("randomize")))
        cells.setdefault(key, []).append(r)
    lines = []
    for (policy, tier, randomize), rs in cells.items():
        worst = min(rs, key=lambda r: r["success_rate"])
        goal = SUCCESS_TARGETS.get((policy, tier, randomize))
        starts = "" if tier is None else f", starts {tier}" + " + randomize" * randomize
        detail = "; ".join(
            f"{r['world']}: {r['successes']}/{r['episodes']} = {r['success_rate']:.2f} "
            f"[{r['success_ci95'][0]:.2f}, {r['success_ci95'][1]:.2f}]"
            for r in rs
        )
        task = f"servo: {POLICY_NAMES.get(policy, policy)}{starts}"
        split = f" on the {worst['split']} split" if worst.get("split") else ""
        measure = (
            f"success rate{split}, lowest world ({worst['world']}; {worst['episodes']} episodes)"
        )
        rate, ci = worst["success_rate"], list(worst["success_ci95"])
        if goal is None:
            lines.append(_line(task, measure, rate, ci, "Wilson 95%", detail=detail))
        else:
            target = f">= {goal:.2f} in every world"
            lines.append(_line(task, measure, rate, ci, "Wilson 95%", target, rate >= goal, detail))
    return lines
