"""Two evaluations of the benchmark protocol compared on the same episodes.

The command is ``topomap servo-compare``.

The protocol's episodes are deterministic from the split (``servo.task.protocol``): two controllers,
or two versions of one, run on the same starts and targets, so their difference is measured
episode by episode rather than as two rates with overlapping intervals. For each world and
setting present in both files this gives the episodes both ran, each side's successes, the
episodes only one side won ("gained" by B, "lost" by B), the exact two-sided sign test on
those discordant episodes (McNemar's exact test), the difference of the success rates with a
paired bootstrap 95 % interval, and the same counts by start manifold.

The files are read as untrusted input: size-limited JSON, every field checked for its form;
two files that disagree on an episode's seed were not run on the same episodes and are
refused.
"""

from __future__ import annotations

import json
from dataclasses import dataclass
from pathlib import Path

import numpy as np
from scipy import stats

from common.fileio import UnreadableJSON, read_json
from common.validation import check_int

__all__ = ["PairedComparison", "compare", "load_results", "markdown"]

MAX_BYTES = 64 << 20  # a 100-episode result file is ~60 kB
SETTING = ("world", "tier", "split", "randomize", "odometry_noise", "max_steps")
BOOTSTRAP = 10_000


@dataclass(frozen=True)
class PairedComparison:
    """Two evaluations of one world and setting, compared episode by episode.

    [`compare`][servo.task.paired_comparison.compare] makes one per world and setting present in
    both results; episodes are paired by their index (and must have the same seed).

    Parameters
    ----------
    setting : dict
        World, tier, split, randomize, odometry_noise and max_steps.
    n : int
        Episodes both ran.
    successes_a, successes_b : int
        Successes of A and of B among them.
    gained, lost : int
        Episodes won by B only, and by A only.
    sign_test_p : float
        Exact two-sided sign test on the ``gained + lost`` episodes.
    difference : float
        B's success rate minus A's.
    difference_ci95 : (float, float)
        Its 95% paired bootstrap interval.
    by_start : dict
        Start manifold -> (episodes, successes of A, successes of B).

    Attributes
    ----------
    setting, n, successes_a, successes_b, gained, lost, sign_test_p, difference
        The parameters (the object is frozen).
    difference_ci95, by_start
        The parameters.

    Examples
    --------
    >>> from servo.task import compare
    >>> def result(successes):
    ...     episodes = [{"episode": i, "seed": 10 + i, "success": s, "start_manifold": "lawn"}
    ...                 for i, s in enumerate(successes)]
    ...     return {"world": "lawn", "tier": "view", "split": "dev", "randomize": False,
    ...             "odometry_noise": True, "max_steps": 600, "episodes_detail": episodes}
    >>> [row] = compare([result([True, False, False])], [result([True, True, False])])
    >>> row.n, row.gained, row.lost, round(row.difference, 3)
    (3, 1, 0, 0.333)

    See Also
    --------
    servo.task.compare : Makes the comparisons.
    servo.task.markdown : Their table.
    servo.task.load_results : Reads ``topomap servo-eval --out`` files.
    """

    setting: dict
    n: int
    successes_a: int
    successes_b: int
    gained: int  # won by B only
    lost: int  # won by A only
    sign_test_p: float  # exact two-sided, on the gained + lost episodes
    difference: float  # B's success rate minus A's
    difference_ci95: tuple[float, float]  # paired bootstrap
    by_start: dict  # start manifold -> (n, successes A, successes B)


def load_results(path: str | Path, name: str = "results") -> list[dict]:
    """Read the result dicts of a ``topomap servo-eval --out`` file.

    Each is checked for the fields the comparison reads; a ``ValueError`` naming ``name`` is
    raised otherwise.

    Parameters
    ----------
    path : str or Path
        The JSON file (a result, a list of results, or a leaderboard envelope around them).
    name : str, default "results"
        The name errors give the file.

    Returns
    -------
    list of dict
        The results.
    """
    path = Path(path)
    if not path.is_file():
        raise ValueError(f"{name}: {path} is not a file")
    if path.stat().st_size > MAX_BYTES:
        raise ValueError(f"{name}: {path} is larger than {MAX_BYTES >> 20} MB")
    try:
        data = read_json(path)
    except UnreadableJSON as err:
        raise ValueError(f"{name}: {path} is not JSON ({err})") from None
    if isinstance(data, dict) and data.get("format") == "topomap-result":
        data = data.get("results")  # the envelope of scripts.leaderboard around the results
    if isinstance(data, dict):
        data = [data]
    if not isinstance(data, list) or not data:
        raise ValueError(f"{name}: expected a servo-eval result (a non-empty list of objects)")
    return [_checked(r, f"{name}[{i}]") for i, r in enumerate(data)]


def _checked(result, where: str) -> dict:
    if not isinstance(result, dict):
        raise ValueError(f"{where}: expected an object, got {type(result).__name__}")
    for key in SETTING:
        if key not in result:
            raise ValueError(f"{where}: missing {key!r}")
    if not isinstance(result["world"], str) or not isinstance(result["tier"], str):
        raise ValueError(f"{where}: 'world' and 'tier' must be strings")
    episodes = result.get("episodes_detail")
    if not isinstance(episodes, list):
        raise ValueError(f"{where}: 'episodes_detail' must be a list of episodes")
    seen = set()
    for j, e in enumerate(episodes):
        here = f"{where}.episodes_detail[{j}]"
        if not isinstance(e, dict):
            raise ValueError(f"{here}: expected an object")
        index, seed = e.get("episode"), e.get("seed")
        if not (_is_int(index) and index >= 0 and _is_int(seed)):
            raise ValueError(f"{here}: 'episode' must be an int >= 0 and 'seed' an int")
        if not isinstance(e.get("success"), bool) or not isinstance(e.get("start_manifold"), str):
            raise ValueError(f"{here}: 'success' must be a bool and 'start_manifold' a string")
        if index in seen:
            raise ValueError(f"{here}: episode {index} appears twice")
        seen.add(index)
    return result


def _is_int(value) -> bool:
    return isinstance(value, int) and not isinstance(value, bool)


def compare(
    a: list[dict], b: list[dict], rng: np.random.Generator | None = None, resamples: int = BOOTSTRAP
) -> list[PairedComparison]:
    """Compare B against A, paired, for every world and setting present in both.

    The comparisons are in A's order; episodes that only one of them ran are left out.

    Parameters
    ----------
    a, b : list of dict
        The results of A and of B ([`load_results`][servo.task.paired_comparison.load_results]).
    rng : numpy.random.Generator, optional
        Draws the bootstrap (default: ``numpy.random.default_rng(0)``, so the same files give
        the same interval).
    resamples : int, default BOOTSTRAP
        The bootstrap's resamples.

    Returns
    -------
    list of PairedComparison
        One per world and setting both ran.
    """
    rng = np.random.default_rng(0) if rng is None else rng
    if not isinstance(rng, np.random.Generator):
        raise TypeError(f"rng must be a numpy.random.Generator, got {type(rng).__name__}")
    resamples = check_int(resamples, "resamples")
    by_setting = {_key(r): r for r in b}
    out = []
    for ra in a:
        rb = by_setting.get(_key(ra))
        if rb is None:
            continue
        eb = {e["episode"]: e for e in rb["episodes_detail"]}
        pairs = [(e, eb[e["episode"]]) for e in ra["episodes_detail"] if e["episode"] in eb]
        for ea, e2 in pairs:
            if ea["seed"] != e2["seed"]:
                raise ValueError(
                    f"episode {ea['episode']} of {ra['world']}/{ra['tier']} has seed "
                    f"{ea['seed']} in one file and {e2['seed']} in the other: not the same "
                    "episodes (another protocol version?)"
                )
        if pairs:
            out.append(_paired(ra, pairs, rng, resamples))
    return out


def _key(result: dict) -> tuple:
    return tuple(json.dumps(result[k]) for k in SETTING)


def _paired(
    setting: dict, pairs: list, rng: np.random.Generator, resamples: int
) -> PairedComparison:
    wa = np.array([ea["success"] for ea, _ in pairs])
    wb = np.array([eb["success"] for _, eb in pairs])
    gained, lost = int(np.sum(wb & ~wa)), int(np.sum(wa & ~wb))
    p = stats.binomtest(gained, gained + lost, 0.5).pvalue if gained + lost else 1.0
    diff = wb.astype(float) - wa.astype(float)
    draws = rng.integers(0, len(diff), size=(resamples, len(diff)))
    lo, hi = np.quantile(diff[draws].mean(axis=1), [0.025, 0.975])
    by_start: dict[str, tuple[int, int, int]] = {}
    for (ea, _), x, y in zip(pairs, wa, wb, strict=True):
        n, sa, sb = by_start.get(ea["start_manifold"], (0, 0, 0))
        by_start[ea["start_manifold"]] = (n + 1, sa + int(x), sb + int(y))
    return PairedComparison(
        setting={k: setting[k] for k in SETTING},
        n=len(pairs),
        successes_a=int(wa.sum()),
        successes_b=int(wb.sum()),
        gained=gained,
        lost=lost,
        sign_test_p=float(p),
        difference=float(diff.mean()),
        difference_ci95=(float(lo), float(hi)),
        by_start=dict(sorted(by_start.items())),
    )


def markdown(rows: list[PairedComparison], a: str = "A", b: str = "B") -> str:
    """Write the comparisons as a markdown table, one row per world and setting.

    Parameters
    ----------
    rows : list of PairedComparison
        The comparisons.
    a, b : str, default "A", "B"
        The names the table gives the two sides.

    Returns
    -------
    str
        The table.
    """
    lines = [
        f"| world | tier | split | settings | episodes | {a} | {b} | gained / lost by {b} | "
        f"sign test p | {b} - {a} [95% bootstrap] | by start manifold ({a} / {b}) |",
        "|---|---|---|---|---|---|---|---|---|---|---|",
    ]
    for r in rows:
        s = r.setting
        extras = ", ".join(
            [f"{s['max_steps']} steps"]
            + ["randomize"] * bool(s["randomize"])
            + ["no odometry noise"] * (not s["odometry_noise"])
        )
        starts = "; ".join(f"{k} {sa}/{sb} of {n}" for k, (n, sa, sb) in r.by_start.items())
        lines.append(
            f"| {s['world']} | {s['tier']} | {s['split']} | {extras} | {r.n} | {r.successes_a} "
            f"| {r.successes_b} | +{r.gained} / -{r.lost} | {r.sign_test_p:.3g} | "
            f"{r.difference:+.3f} [{r.difference_ci95[0]:+.3f}, {r.difference_ci95[1]:+.3f}] "
            f"| {starts} |"
        )
    return "\n".join(lines)
