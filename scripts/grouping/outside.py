r"""``topomap group-eval --method``: any grouping estimator scored like the observation grouping.

    topomap group-eval --method mapping.grouping:ObservationGraphPartitioner \
        --data ROOT/m-data-1 [--data ROOT/m-data-2 ...] --out OUT [--local-maps]
    topomap group-eval --method sklearn.cluster:DBSCAN --param eps=2.0 --input positions \
        --carmen LOG [--carmen LOG ...] --out OUT

The estimator is built with ``--param`` and fitted per case: ``fit(scans, poses)`` (scans:
a list of ``(m_i, 2)`` point arrays in the laser frame, poses: ``(n, 3)`` x, y, heading),
with ``groups=`` (the drive each frame belongs to) where ``fit`` takes it; with ``--input
positions`` a plain clusterer gets ``fit(poses[:, :2])``. Its ``labels_`` are the groups.

* Simulated datasets (``--data``, each world a case, with the true poses and with the noisy
  odometry): ``score_groups`` against the ground-truth manifolds (purity, ARI, groups per
  manifold); the ranked metric is the ARI, one unit per (dataset seed, world). With
  ``--local-maps`` a second file scores the groups as local maps (below).
* Carmen logs (``--carmen``, the log's corrected poses): no ground truth of places, so the
  groups are scored as local maps only: each group of the training scans (all but every fifth)
  is rebuilt by ICP and every held-out scan is localised against its group's map
  (``scripts.grouping.local_maps``: success within 0.1 m and 2 degrees); one unit per
  held-out scan, a Wilson interval over them.

A case where the estimator raises is recorded with the reason and the run goes on.
"""

from __future__ import annotations

import inspect
import re
import time
import warnings
from pathlib import Path

import numpy as np

from scripts.grouping.local_maps import SUCCESS, split, submap_errors
from scripts.grouping.scores import meets_targets, score_groups
from scripts.leaderboard import OutsideMethod, envelope, parse_params, write_result

__all__ = ["INPUTS", "PROTOCOLS", "evaluate_carmen_method", "evaluate_worlds_method", "run"]

TASK = "observation-grouping"
# name and version of each protocol in result files; the version goes up whenever a change
# alters the numbers a method gets (datasets, poses, held-out split, success test, scores)
PROTOCOLS = {
    "worlds": ("observation-grouping-worlds", 1),
    "local-maps": ("observation-grouping-local-maps", 1),
    "carmen": ("observation-grouping-carmen", 1),
}
INPUTS = ("scans", "positions")
HOLD_EVERY = 5
POSES = ("true", "odometry")
DEV_SEED = 0  # the dataset the partitioner's settings were chosen on


def _fit(method: OutsideMethod, scans, poses, groups, given: str) -> np.ndarray:
    """Fit the estimator on one case and return its groups.

    ``ValueError`` when it leaves no proper ``labels_``.
    """
    model = method.make()
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")  # the estimator's warnings are its own business here
        if given == "positions":
            model.fit(np.asarray(poses)[:, :2])
        elif "groups" in _fit_parameters(model):
            model.fit(scans, poses, groups=groups)
        else:
            model.fit(scans, poses)
    labels = getattr(model, "labels_", None)
    if labels is None:
        raise ValueError("fit left no labels_ attribute")
    labels = np.asarray(labels)
    if labels.shape != (len(poses),) or not np.issubdtype(labels.dtype, np.integer):
        raise ValueError(
            f"labels_ must be {len(poses)} integers, got {labels.dtype} {labels.shape}"
        )
    # noise (-1, as DBSCAN marks it) becomes singleton groups: every scan is in some map
    if (labels < 0).any():
        labels = labels.copy()
        labels[labels < 0] = labels.max() + 1 + np.arange(int((labels < 0).sum()))
    return labels


def _fit_parameters(model) -> set[str]:
    try:
        return set(inspect.signature(model.fit).parameters)
    except (TypeError, ValueError):
        return set()


def _failure(err: Exception) -> str:
    return f"{type(err).__name__}: {err}"[:500]


def _localised(errors: np.ndarray) -> list[bool]:
    return [bool(t <= SUCCESS[0] and h <= SUCCESS[1]) for t, h in errors]


def _local_map_records(method, scans, truth, poses, groups, rng, given, group, unit):
    """One record per held-out scan: localised against its group's map or not."""
    train, held, _ = split(groups, HOLD_EVERY)
    try:
        labels = _fit(method, [scans[i] for i in train], poses[train], groups[train], given)
        errors, _, _ = submap_errors(
            scans, truth, poses, groups, labels, rng, hold_every=HOLD_EVERY
        )
    except Exception as err:  # an outside estimator may raise anything
        return [
            {
                "group": group,
                "unit": f"{unit}/scan {int(i)}",
                "value": None,
                "failure": _failure(err),
            }
            for i in held
        ]
    return [
        {"group": group, "unit": f"{unit}/scan {int(i)}", "value": ok, "failure": None}
        for i, ok in zip(held, _localised(errors), strict=True)
    ]


def evaluate_worlds_method(
    method: OutsideMethod, datasets, given="scans", local_maps=False, seed: int = 0, progress=True
) -> list[dict]:
    """Evaluate ``method`` on simulated ``datasets`` into result files.

    Parameters
    ----------
    method : OutsideMethod
        The estimator.
    datasets : iterable of str or os.PathLike
        The simulated datasets, each of another seed; the dev seed only alone.
    given : {"scans", "positions"}, default "scans"
        What the estimator's ``fit`` gets: scans and poses, or the (x, y) positions.
    local_maps : bool, default False
        Whether to also score the held-out localisation against its groups.
    seed : int, default 0
        Seed of the localisation's random numbers.
    progress : bool, default True
        Whether to show a progress bar.

    Returns
    -------
    list of dict
        The result file of the grouping scores (ARI per seed and world) and, with
        ``local_maps``, that of the held-out localisation.

    Raises
    ------
    ValueError
        When a dataset has no ground truth, a seed is given twice, or the dev seed comes with
        others.
    """
    from tqdm.auto import tqdm

    from sim.dataset import load_dataset

    rng = np.random.default_rng(seed)
    scores, maps = [], []
    loaded = [load_dataset(d) for d in datasets]  # read (and check) all before any work
    seeds = {}
    for data in loaded:
        if not data.has_ground_truth:
            raise ValueError(f"{data.path}: scoring groups needs a simulated dataset")
        seed = data.meta["settings"]["seed"]
        if seed in seeds:
            raise ValueError(
                f"{data.path} and {seeds[seed]} are both of seed {seed}: "
                "give each dataset seed once"
            )
        seeds[seed] = data.path
    if DEV_SEED in seeds and len(seeds) > 1:
        raise ValueError(
            f"seed {DEV_SEED} is the dev seed (the settings were chosen on it): "
            "evaluate it apart from fresh seeds"
        )
    split = "dev" if DEV_SEED in seeds else "test"
    cases = [(d, w, v) for d in loaded for w in d.worlds for v in POSES]
    for data, world, variant in tqdm(cases, disable=not progress, desc="group-eval"):
        runs = data.runs(world)
        poses = runs.poses if variant == "true" else runs.odometry
        unit = f"seed {data.meta['settings']['seed']}/{world}"
        record = {"group": variant, "unit": unit}
        start = time.perf_counter()
        try:
            labels = _fit(method, runs.scans, poses, runs.groups, given)
        except Exception as err:  # an outside estimator may raise anything
            record.update(value=None, failure=_failure(err))
        else:
            score = score_groups(runs.labels, labels, runs.manifold_names)
            record.update(
                value=score["ari"],
                failure=None,
                purity=score["purity"],
                groups=score["groups"],
                meets_targets=meets_targets(score),
                max_groups_per_manifold=score["max_groups_per_manifold"],
                seconds=time.perf_counter() - start,
            )
        scores.append(record)
        if local_maps:
            maps += _local_map_records(
                method, runs.scans, runs.poses, poses, runs.groups, rng, given, variant, unit
            )
    described = {**method.describe(), "input": given}
    settings = {"datasets": [str(d.path) for d in loaded], "poses": list(POSES)}
    out = [
        envelope(
            TASK, PROTOCOLS["worlds"], split, described, ("ari", "score"), scores, settings=settings
        )
    ]
    if local_maps:
        out.append(
            envelope(
                TASK,
                PROTOCOLS["local-maps"],
                split,
                described,
                ("localised", "rate"),
                maps,
                settings=_map_settings(settings),
            )
        )
    return out


def _map_settings(settings: dict) -> dict:
    return {
        **settings,
        "hold_every": HOLD_EVERY,
        "success": {"translation_m": SUCCESS[0], "heading_deg": 2.0},
    }


def evaluate_carmen_method(
    method: OutsideMethod, logs, given="scans", seed: int = 0, progress=True
) -> dict:
    """Evaluate ``method`` on Carmen ``logs``: held-out localisation against its groups.

    Each log's corrected poses are used.

    Parameters
    ----------
    method : OutsideMethod
        The estimator.
    logs : iterable of str or os.PathLike
        The Carmen logs.
    given : {"scans", "positions"}, default "scans"
        What the estimator's ``fit`` gets: scans and poses, or the (x, y) positions.
    seed : int, default 0
        Seed of the localisation's random numbers.
    progress : bool, default True
        Whether to show a progress bar.

    Returns
    -------
    dict
        The result file, one record per held-out scan.
    """
    from tqdm.auto import tqdm

    from scripts.grouping.carmen_logs import log_points
    from sim.readers import read_carmen

    rng = np.random.default_rng(seed)
    read = [read_carmen(p) for p in logs]  # read (and check) all before any work is done
    records = []
    for log in tqdm(read, disable=not progress, desc="group-eval carmen"):
        tag = log.path.name.split(".")[0]
        groups = np.zeros(len(log), dtype=int)  # one drive
        records += _local_map_records(
            method, log_points(log), log.poses, log.poses, groups, rng, given, tag, tag
        )
    described = {**method.describe(), "input": given}
    settings = _map_settings({"logs": [str(log.path) for log in read], "poses": "given"})
    return envelope(
        TASK,
        PROTOCOLS["carmen"],
        "test",
        described,
        ("localised", "rate"),
        records,
        settings=settings,
    )


def file_name(result: dict) -> str:
    """Name a result file ``<protocol>-<input>-<spec>[-<params digest>].json``.

    The spec part is ``scripts.leaderboard.files.file_tag``'s; the name is safe on every file
    system.

    Parameters
    ----------
    result : dict
        A result file of this module.

    Returns
    -------
    str
        The file name.
    """
    from scripts.leaderboard import file_tag

    m = result["method"]
    tag = file_tag(m.get("spec") or m["name"], m["params"])
    stem = f"{result['protocol']['name']}-{m['input']}-{tag}"
    return re.sub(r"[^A-Za-z0-9=.,_-]+", "_", stem) + ".json"


def add_arguments(p) -> None:
    """Add the ``--method`` options of ``topomap group-eval``.

    Parameters
    ----------
    p : argparse.ArgumentParser
        The parser.
    """
    p.add_argument(
        "--method",
        default=None,
        metavar="MODULE:CLASS",
        help="score this estimator (fit(scans, poses), labels_) instead of running "
        "the built-in evaluation; its module is imported like python -m, so its "
        "code runs (docs/guides/benchmark-your-method.md)",
    )
    p.add_argument(
        "--param",
        action="append",
        default=[],
        metavar="KEY=VALUE",
        help="constructor argument of --method (a Python literal or text)",
    )
    p.add_argument(
        "--input",
        choices=INPUTS,
        default="scans",
        help="what --method's fit gets: scans and poses, or the (x, y) positions",
    )


def run(args) -> int:
    """Run ``topomap group-eval --method ...``: result files in ``--out``, then their ranking.

    Parameters
    ----------
    args : argparse.Namespace
        ``method``, ``param``, ``input``, ``out``, ``carmen`` or ``data``, ``local_maps``
        and ``quiet``.

    Returns
    -------
    int
        The exit status, 0.
    """
    from scripts.leaderboard import leaderboard_markdown

    method = OutsideMethod(args.method, ("fit",), parse_params(args.param))
    out = Path(args.out)
    out.mkdir(parents=True, exist_ok=True)
    if args.carmen:
        results = [evaluate_carmen_method(method, args.carmen, args.input, progress=not args.quiet)]
    else:
        results = evaluate_worlds_method(
            method, args.data, args.input, args.local_maps, progress=not args.quiet
        )
    for result in results:
        path = write_result(out / file_name(result), result)
        failed = {r["failure"] for r in result["records"] if r["failure"]}
        print(f"wrote {path}" + "".join(f"\n  failed: {f}" for f in sorted(failed)))
    print()
    print(leaderboard_markdown([{**r, "_path": "this run"} for r in results]))
    return 0
