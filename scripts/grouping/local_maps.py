"""Test the grouping on what Blanco et al. claim: consistent local maps.

    topomap group-eval --data DIR --carmen LOG [--carmen LOG] --local-maps --out DIR

For every case (a world's default sequences, its loop, a real Carmen log) and two kinds of
poses, the training scans (all but every ``hold_every``-th) are cut into submaps four ways:

* ``grouping``: ``ObservationGraphPartitioner(scan_matching=False)`` on the case's poses;
* ``every n scans`` and ``every d m``: the baselines a user would pick, sized to the
  grouping's median group (scans, and metres travelled) so that only *where* the cuts fall
  differs;
* ``global``: one map of everything at the case's poses (what the submaps are meant to beat).

Each submap is rebuilt by scan-to-map ICP (``mapping.grouping.local_maps.align_group``); then its
consistency (point-to-nearest-point residuals between its scans) and how well the held-out
scans localise against it (relative pose error against a neighbour scan in the map; success:
within 0.1 m and 2 degrees, Wilson 95 % interval) are measured.

Poses: ``true`` (worlds: the simulator's; logs: the log's corrected SLAM poses, taken as
truth) and ``odometry+icp`` (worlds: the dataset's noisy odometry; logs: odometry simulated
from the corrected poses with ``sim.odometry``'s default noise, seed 0), chained by sequential
ICP (``mapping.scan_matching.refine_poses``), as the partitioner does by default.
"""

from __future__ import annotations

import os
import time
from pathlib import Path

import numpy as np
from scipy import stats

from common.geometry import transform_points
from mapping.grouping import (
    ObservationGraphPartitioner,
    align_groups,
    localise_held_out,
    map_residuals,
    submap_labels,
)
from mapping.run_starts import run_starts_from_groups
from mapping.scan_matching import densify_scan, refine_poses
from sim.odometry import Odometry, OdometryConfig

__all__ = [
    "JSON_FILE",
    "evaluate_case",
    "format_report",
    "score_submaps",
    "simulated_odometry",
    "split",
    "submap_errors",
]

JSON_FILE = "local_maps.json"
SUCCESS = (0.1, np.deg2rad(2.0))  # localised: relative pose within 0.1 m and 2 degrees
METHODS = ("grouping", "every n scans", "every d m", "global")


def simulated_odometry(poses: np.ndarray, seed: int = 0) -> np.ndarray:
    """Simulate noisy odometry from true poses with ``sim.odometry``'s default noise.

    The noise is the dataset's.

    Parameters
    ----------
    poses : ndarray of shape (n, 3)
        True poses (x, y, heading).
    seed : int, default 0
        Seed of the noise.

    Returns
    -------
    ndarray of shape (n, 3)
        The odometry poses.
    """
    odo = Odometry(OdometryConfig(), np.random.default_rng(seed))
    out = [odo.reset(poses[0])]
    out += [odo.update(p) for p in poses[1:]]
    return np.asarray(out)


def split(groups: np.ndarray, hold_every: int) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Split the scans into training and held-out scans.

    Parameters
    ----------
    groups : ndarray of shape (n,)
        The run of each scan.
    hold_every : int
        Every ``hold_every``-th scan of each run is held out, never a run's first.

    Returns
    -------
    train : ndarray of int
        Indices of the training scans.
    held : ndarray of int
        Indices of the held-out scans.
    anchor : ndarray of int
        Each held-out scan's anchor: the training scan just before it.
    """
    n = len(groups)
    starts = run_starts_from_groups(groups, n)
    run_index = np.arange(n) - np.maximum.accumulate(np.where(starts, np.arange(n), 0))
    held = (run_index % hold_every == hold_every // 2 + 1) & (run_index > 0)
    return np.flatnonzero(~held), np.flatnonzero(held), np.flatnonzero(held) - 1


def _rates(errors: np.ndarray, rng: np.random.Generator) -> dict:
    ok = (errors[:, 0] <= SUCCESS[0]) & (errors[:, 1] <= SUCCESS[1])
    k, n = int(ok.sum()), len(ok)
    ci = stats.binomtest(k, n).proportion_ci(method="wilson") if n else None
    finite = errors[np.isfinite(errors[:, 0]), 0]
    median = float(np.median(finite)) if finite.size else None
    if finite.size >= 2 and np.ptp(finite) > 0:
        boot = stats.bootstrap((finite,), np.median, n_resamples=1000, random_state=rng)
        median_ci = [float(boot.confidence_interval.low), float(boot.confidence_interval.high)]
    else:
        median_ci = None
    return {
        "held_out": n,
        "localised": k,
        "rate": k / n if n else None,
        "rate_ci95": [float(ci.low), float(ci.high)] if ci else None,
        "converged": int(np.isfinite(errors[:, 0]).sum()),
        "median_error_m": median,
        "median_error_ci95": median_ci,
    }


def _group_travel(poses: np.ndarray, labels: np.ndarray) -> float:
    steps = np.hypot(*np.diff(poses[:, :2], axis=0).T)
    same = labels[1:] == labels[:-1]
    per = np.bincount(labels[1:][same], weights=steps[same], minlength=labels.max() + 1)
    return float(np.median(per))


def evaluate_case(
    scans: list[np.ndarray],
    truth: np.ndarray,
    poses: np.ndarray,
    groups: np.ndarray,
    rng: np.random.Generator,
    *,
    hold_every: int = 5,
) -> dict:
    """Score all four methods on one case with one kind of ``poses``.

    Parameters
    ----------
    scans : list of ndarray
        Each scan's points in the laser frame.
    truth : ndarray of shape (n, 3)
        True poses, which score the methods.
    poses : ndarray of shape (n, 3)
        The poses the submaps are built at.
    groups : ndarray of shape (n,)
        The run of each scan.
    rng : numpy.random.Generator
        Random numbers of the localisation and the bootstrap.
    hold_every : int, default 5
        Every ``hold_every``-th scan of each run is held out.

    Returns
    -------
    dict
        The counts of training and held-out scans, the grouping's time, the baselines'
        sizes, and ``score_submaps`` of each method.
    """
    train, held, _ = split(groups, hold_every)
    tscans = [scans[i] for i in train]
    tposes, tgroups = poses[train], groups[train]
    start = time.perf_counter()
    model = ObservationGraphPartitioner(scan_matching=False).fit(tscans, tposes, groups=tgroups)
    grouping_s = time.perf_counter() - start
    sizes = np.bincount(model.labels_[model.labels_ >= 0])
    n_scans = max(2, round(float(np.median(sizes))))
    distance = max(_group_travel(tposes, model.labels_), 0.5)
    labels = {
        "grouping": model.labels_,
        "every n scans": submap_labels(tposes, n_scans=n_scans, groups=tgroups),
        "every d m": submap_labels(tposes, distance=distance, groups=tgroups),
        "global": np.zeros(len(train), dtype=int),
    }
    out = {"train": len(train), "held_out": len(held), "grouping_seconds": grouping_s}
    out["baseline_sizes"] = {"n_scans": n_scans, "distance_m": distance}
    for name, lab in labels.items():
        # the global map is the mapper's own: its poses as given, not re-aligned
        out[name] = score_submaps(
            scans, truth, poses, groups, lab, rng, hold_every=hold_every, align=name != "global"
        )
    return out


def score_submaps(
    scans: list[np.ndarray],
    truth: np.ndarray,
    poses: np.ndarray,
    groups: np.ndarray,
    labels: np.ndarray,
    rng: np.random.Generator,
    *,
    hold_every: int = 5,
    align: bool = True,
) -> dict:
    """Consistency and held-out localisation of one cut of the training scans into submaps.

    Each submap is rebuilt by scan-to-map ICP (unless ``align`` is False) and scored.

    Parameters
    ----------
    scans : list of ndarray
        Each scan's points in the laser frame.
    truth : ndarray of shape (n, 3)
        True poses.
    poses : ndarray of shape (n, 3)
        The poses the submaps are built at.
    groups : ndarray of shape (n,)
        The run of each scan.
    labels : ndarray of int
        The submap of each *training* scan (``split(groups, hold_every)[0]``).
    rng : numpy.random.Generator
        Random numbers of the localisation and the bootstrap.
    hold_every : int, default 5
        Every ``hold_every``-th scan of each run is held out.
    align : bool, default True
        Whether each submap is rebuilt by scan-to-map ICP.

    Returns
    -------
    dict
        ``submaps`` (their number), ``residuals`` (``map_residuals``) and
        ``localisation`` (held-out success rate and median error, with intervals).
    """
    errors, aligned, train = submap_errors(
        scans, truth, poses, groups, labels, rng, hold_every=hold_every, align=align
    )
    labels = np.asarray(labels)
    return {
        "submaps": len(np.unique(labels)),
        "residuals": map_residuals([scans[i] for i in train], aligned, labels),
        "localisation": _rates(errors, rng),
    }


def submap_errors(scans, truth, poses, groups, labels, rng, *, hold_every=5, align=True):
    """Localise the held-out scans against the submaps of `score_submaps`.

    Parameters
    ----------
    scans, truth, poses, groups, labels, rng, hold_every, align
        As in `score_submaps`.

    Returns
    -------
    errors : ndarray of shape (n_held, 2)
        Each held-out scan's translation and heading error (``inf``: ICP did not converge).
    aligned : ndarray of shape (n_train, 3)
        The aligned training poses.
    train : ndarray of int
        The training indices.

    Raises
    ------
    ValueError
        When ``labels`` has not one entry per training scan.
    """
    train, held, anchor = split(groups, hold_every)
    labels = np.asarray(labels)
    if labels.shape != (len(train),):
        raise ValueError(f"labels must have one entry per training scan ({len(train)},)")
    tscans, tposes = [scans[i] for i in train], poses[train]
    aligned = align_groups(tscans, tposes, labels) if align else tposes.copy()
    full = poses.copy()
    full[train] = aligned
    maps = {
        int(g): np.concatenate(
            [
                transform_points(aligned[k], densify_scan(tscans[k]))
                for k in np.flatnonzero(labels == g)
            ]
        )
        for g in np.unique(labels)
    }
    # held-out scan -> position of its anchor among the training scans
    anchor_pos = np.searchsorted(train, anchor)
    errors = localise_held_out(scans, full, truth, held, anchor, maps, labels[anchor_pos], rng)
    return errors, aligned, train


def evaluate_cases(cases: dict, out_dir: str | os.PathLike, *, seed: int = 0, progress=True):
    """Evaluate every case with true and ICP-refined odometry poses; write ``local_maps.json``.

    Parameters
    ----------
    cases : dict
        Name -> (scans, truth, odometry, groups).
    out_dir : str or os.PathLike
        The output directory, created if missing.
    seed : int, default 0
        Seed of the random numbers.
    progress : bool, default True
        Whether to show a progress bar.

    Returns
    -------
    dict
        Everything written to ``local_maps.json``: the settings, and per case and poses
        ``evaluate_case``'s result.
    """
    from tqdm.auto import tqdm

    from common.fileio import write_json

    rng = np.random.default_rng(seed)
    result = {
        "settings": {
            "hold_every": 5,
            "success": {"translation_m": SUCCESS[0], "heading_deg": 2.0},
            "init_noise": {"translation_m": 0.2, "heading_rad": 0.05},
            "seed": seed,
            "cpu_count": os.cpu_count(),
        },
        "cases": {},
    }
    bar = tqdm(total=2 * len(cases), desc="local maps", disable=not progress)
    try:
        for name, (scans, truth, odometry, groups) in cases.items():
            result["cases"][name] = {}
            for variant in ("true", "odometry+icp"):
                bar.set_postfix_str(f"{name} {variant}")
                poses = truth if variant == "true" else refine_poses(scans, odometry, groups=groups)
                result["cases"][name][variant] = evaluate_case(scans, truth, poses, groups, rng)
                bar.update()
    finally:
        bar.close()
    out_dir = Path(out_dir)
    out_dir.mkdir(parents=True, exist_ok=True)
    write_json(out_dir / JSON_FILE, result)
    return result


def format_report(result: dict) -> str:
    """Format a markdown table, one row per case, poses and method.

    Parameters
    ----------
    result : dict
        The result of ``evaluate_cases``.

    Returns
    -------
    str
        The table.
    """
    lines = [
        "| case | poses | method | submaps | residual mean / p90 (cm) | matched | localised "
        "(95 % CI) | median error (cm) |",
        "|---|---|---|---|---|---|---|---|",
    ]
    for case, variants in result["cases"].items():
        for variant, e in variants.items():
            for m in METHODS:
                r, loc = e[m]["residuals"], e[m]["localisation"]
                lo, hi = loc["rate_ci95"] or (float("nan"), float("nan"))
                med = loc["median_error_m"]
                lines.append(
                    f"| {case} | {variant} | {m} | {e[m]['submaps']} "
                    f"| {100 * r['mean_m']:.1f} / {100 * r['p90_m']:.1f} | {r['matched']:.3f} "
                    f"| {loc['localised']}/{loc['held_out']} ({lo:.2f}-{hi:.2f}) "
                    f"| {'--' if med is None else f'{100 * med:.1f}'} |"
                )
    return "\n".join(lines)


def dataset_cases(data, out_dir, *, loop: bool = True, loop_frames: int | None = None) -> dict:
    """Build the cases of a simulated dataset: each world's default sequences, and its loop.

    Parameters
    ----------
    data : Dataset or str or os.PathLike
        The dataset, with true poses.
    out_dir : str or os.PathLike
        The output directory; the loops are cached in its ``loop/``.
    loop : bool, default True
        Whether to add each world's loop.
    loop_frames : int, optional
        Frames of each loop; by default the dataset's spacing.

    Returns
    -------
    dict
        Name -> (scans, truth, odometry, groups).

    Raises
    ------
    ValueError
        When the dataset has no true poses.
    """
    from scripts.grouping.loop_recordings import collect_loop, has_loop
    from sim import dataset as ds
    from sim.collect_worlds import label_space
    from sim.runs import Runs

    dataset = data if isinstance(data, ds.Dataset) else ds.load_dataset(data)
    if not dataset.has_ground_truth:
        raise ValueError(f"{dataset.path}: the local-map evaluation needs true poses")
    cases = {}
    for world in dataset.worlds:
        runs = [dataset.runs(world)]
        if loop and has_loop(world):
            seq = collect_loop(world, Path(out_dir) / "loop", frames=loop_frames)
            runs.append(Runs.from_sequences([seq], dataset.max_range, label_space((world,))))
        for tag, r in zip((world, f"{world} loop"), runs, strict=False):
            cases[tag] = (r.scans, r.poses, r.odometry, r.groups)
    return cases


def carmen_cases(paths) -> dict:
    """Build the cases of Carmen logs: corrected poses as truth, odometry simulated from them.

    Parameters
    ----------
    paths : iterable of str or os.PathLike
        The Carmen logs.

    Returns
    -------
    dict
        Log name -> (scans, truth, odometry, groups), all scans in one run.
    """
    from scripts.grouping.carmen_logs import log_points
    from sim.readers import read_carmen

    cases = {}
    for path in paths:
        log = read_carmen(path)
        tag = log.path.name.split(".")[0]
        groups = np.zeros(len(log), dtype=int)
        cases[tag] = (log_points(log), log.poses, simulated_odometry(log.poses), groups)
    return cases


def run(args) -> int:
    """Run ``topomap group-eval (--data DIR | --carmen LOG ...) --local-maps --out DIR``.

    Parameters
    ----------
    args : argparse.Namespace
        ``data`` or ``carmen``, ``out``, ``no_loop``, ``loop_frames``, ``quiet`` and ``json``.

    Returns
    -------
    int
        The exit status, 0.
    """
    import json

    if args.carmen:
        cases = carmen_cases(args.carmen)
    else:
        cases = dataset_cases(
            args.data, args.out, loop=not args.no_loop, loop_frames=args.loop_frames
        )
    result = evaluate_cases(cases, args.out, progress=not args.quiet)
    print(json.dumps(result, indent=2) if args.json else format_report(result))
    if not args.json:
        print(f"\nwrote {Path(args.out) / JSON_FILE}")
    return 0
