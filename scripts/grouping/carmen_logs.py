"""Run the laser observation grouping (Blanco et al.) on real robot logs in the Carmen format.

    topomap group-eval --carmen LOG [--carmen LOG ...] --out DIR [--json]

Each log's scans (``sim.readers.carmen.read_carmen``; beams at the sensor's maximum range are no
returns) are grouped by ``ObservationGraphPartitioner`` at its default settings with the log's
own poses (the corrected, SLAM-quality poses of a "corrected" log: the paper's setting), once
without scan matching and once with it (ICP from the given poses). There is no ground truth of
places in a real log, so the results are the groups themselves: their number and sizes, the
topology, how far ICP moved the poses, and the time. Writes ``carmen.json`` and, for the
grouping without ICP, the four figures (groups over the map, local maps, weights, topology)
per log into the output directory.
"""

from __future__ import annotations

import json
import os
import time
from collections.abc import Sequence
from pathlib import Path

import numpy as np

from common.fileio import write_json
from common.geometry import scan_to_points
from mapping.grouping import ObservationGraphPartitioner
from scripts.grouping import plots as gp
from sim.readers import CarmenLog, read_carmen

__all__ = ["JSON_FILE", "evaluate_carmen", "format_report", "group_log", "run"]

JSON_FILE = "carmen.json"
VARIANTS = {"given": False, "given+icp": True}  # name -> scan_matching


def log_points(log: CarmenLog) -> list[np.ndarray]:
    """Return each scan's returns as points in the laser frame (no-returns dropped).

    Parameters
    ----------
    log : CarmenLog
        The log read by ``sim.readers.carmen.read_carmen``.

    Returns
    -------
    list of ndarray
        One array of points per scan.
    """
    return [scan_to_points(r, log.angles, log.max_range) for r in log.ranges]


def group_log(
    log: CarmenLog, scans: Sequence[np.ndarray], scan_matching: bool
) -> tuple[ObservationGraphPartitioner, dict]:
    """Fit the partitioner at default settings on one log with its own poses.

    Parameters
    ----------
    log : CarmenLog
        The log, whose poses are used.
    scans : sequence of ndarray
        Each scan's points in the laser frame (``log_points``).
    scan_matching : bool
        Whether the partitioner corrects the poses by ICP.

    Returns
    -------
    model : ObservationGraphPartitioner
        The fitted model.
    summary : dict
        A summary of its groups: their number and sizes, singletons, arcs, overlap pairs per
        scan, the largest pose change (m) and the time (s).
    """
    model = ObservationGraphPartitioner(scan_matching=scan_matching)
    start = time.perf_counter()
    model.fit(scans, log.poses)
    seconds = time.perf_counter() - start
    sizes = np.bincount(model.labels_[model.labels_ >= 0], minlength=model.n_groups_)
    moved = np.hypot(*(model.poses_[:, :2] - log.poses[:, :2]).T)
    W = model.affinity_matrix_
    return model, {
        "groups": model.n_groups_,
        "group_size": {
            "min": int(sizes.min()),
            "median": float(np.median(sizes)),
            "max": int(sizes.max()),
        },
        "singletons": int(np.sum(sizes == 1)),
        "arcs": len(model.topology_.arcs),
        "overlap_pairs_per_scan": float((W.nnz - W.shape[0]) / W.shape[0]),
        "max_pose_change_m": float(moved.max()),
        "seconds": seconds,
    }


def _point_cloud_background(log: CarmenLog, scans: Sequence[np.ndarray]):
    from mapping.grouping import world_points

    cloud = np.concatenate(world_points(scans, log.poses))

    def draw(ax):
        ax.scatter(cloud[:, 0], cloud[:, 1], s=0.2, color="0.75", linewidths=0, zorder=0)

    return draw


def evaluate_carmen(
    paths: Sequence[str | os.PathLike],
    out_dir: str | os.PathLike,
    *,
    figures: bool = True,
    progress: bool = True,
) -> dict:
    """Group every log of ``paths`` without and with ICP; write ``carmen.json`` and figures.

    Parameters
    ----------
    paths : sequence of str or os.PathLike
        The Carmen logs; at least one.
    out_dir : str or os.PathLike
        The output directory, created if missing.
    figures : bool, default True
        Whether to write the four figures per log (for the grouping without ICP).
    progress : bool, default True
        Whether to show a progress bar.

    Returns
    -------
    dict
        Everything written to ``carmen.json``: per log (by file stem) the log's size and, per
        variant (``"given"``, ``"given+icp"``), the summary of ``group_log``.
    """
    from tqdm.auto import tqdm

    if not paths:
        raise ValueError("paths is empty: give at least one Carmen log")
    logs = [read_carmen(p) for p in paths]  # read (and check) all before any work is done
    out_dir = Path(out_dir)
    out_dir.mkdir(parents=True, exist_ok=True)
    result = {
        "settings": {
            "partitioner": "ObservationGraphPartitioner() defaults (threshold 1, delta 0.1 m, "
            "assoc mrpt, normalized Laplacian); poses: the log's own",
            "variants": {name: f"scan_matching={flag}" for name, flag in VARIANTS.items()},
            "cpu_count": os.cpu_count(),
        },
        "logs": {},
        "figures": [],
    }
    bar = tqdm(total=len(logs) * len(VARIANTS), desc="carmen", disable=not progress)
    try:
        for log in logs:
            tag = log.path.name.split(".")[0]
            scans = log_points(log)
            entry = {
                "file": str(log.path),
                "message": log.message,
                "scans": len(log),
                "beams": int(log.ranges.shape[1]),
                "points": int(sum(len(s) for s in scans)),
                "max_range_m": log.max_range,
                "path_length_m": float(np.hypot(*np.diff(log.poses[:, :2], axis=0).T).sum()),
            }
            for name, flag in VARIANTS.items():
                bar.set_postfix_str(f"{tag} {name}")
                model, entry[name] = group_log(log, scans, flag)
                bar.update()
                if figures and not flag:
                    background = _point_cloud_background(log, scans)
                    paths_written = gp.write_grouping_figures(
                        out_dir, tag, scans, model, background, "; grey: all scans"
                    )
                    result["figures"] += [p.name for p in paths_written]
            given, icp = entry["given"]["seconds"], entry["given+icp"]["seconds"]
            entry["icp_time_ratio"] = icp / given if given > 0 else None
            result["logs"][tag] = entry
    finally:
        bar.close()
    write_json(out_dir / JSON_FILE, result)
    return result


def format_report(result: dict) -> str:
    """Format a markdown table of the groupings of every log.

    Parameters
    ----------
    result : dict
        The result of ``evaluate_carmen``.

    Returns
    -------
    str
        The table, one row per log and variant.
    """
    lines = [
        "| log | scans x beams | poses | groups | size min / median / max | singletons | arcs "
        "| max ICP change (m) | time (s) |",
        "|---|---|---|---|---|---|---|---|---|",
    ]
    for tag, e in result["logs"].items():
        for name in VARIANTS:
            s = e[name]
            size = s["group_size"]
            lines.append(
                f"| {tag} | {e['scans']} x {e['beams']} | {name} | {s['groups']} "
                f"| {size['min']} / {size['median']:g} / {size['max']} | {s['singletons']} "
                f"| {s['arcs']} | {s['max_pose_change_m']:.2f} | {s['seconds']:.2f} |"
            )
    return "\n".join(lines)


def run(args) -> int:
    """Run ``topomap group-eval --carmen LOG ... --out DIR``.

    Parameters
    ----------
    args : argparse.Namespace
        ``carmen``, ``out``, ``quiet`` and ``json``.

    Returns
    -------
    int
        The exit status, 0.
    """
    result = evaluate_carmen(args.carmen, args.out, progress=not args.quiet)
    if args.json:
        print(json.dumps(result, indent=2))
    else:
        print(format_report(result))
        print(f"\nwrote {Path(args.out) / JSON_FILE} and {len(result['figures'])} figures")
    return 0
