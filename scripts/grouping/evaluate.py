"""Evaluate the laser observation grouping (Blanco et al.) on the simulated worlds.

    python -m scripts.grouping.evaluate --data out/dataset --out out/grouping [--json]
    topomap group-eval --data out/dataset --out out/grouping [--json]

For each world, the default dataset's three sequences (main manifold, then one branch each) are
grouped together in one observation graph (``groups``: the drive each frame belongs to), with
the noisy odometry poses, without and with ICP refinement, and with the true poses as a
reference. A longer loop through each world (main -> every branch, back to the junction between
them; ``scripts.grouping.loop_recordings``) is grouped the same way. Groups are scored against the
ground-truth manifolds. Then both sensors meet both methods: the recursive min-Ncut partition
on the scans' overlap and on an image-similarity graph, and the manifold clustering
(Grudic & Mulligan) on scan features and on images.

Writes ``grouping.json`` (every number), ``groups.npz`` (every frame's group) and PNG figures
like the paper's Figures 3 and 5 into the output directory.

A dataset without ground truth (imported from a robot's log, ``topomap import``) is grouped and
drawn the same way, with odometry only and no scores: its tables say "no ground-truth labels".
"""

from __future__ import annotations

import argparse
import json
import os
import time
from collections.abc import Sequence
from pathlib import Path

import numpy as np

from common.fileio import jsonable, write_json
from mapping.grouping import ObservationGraphPartitioner
from scripts.grouping import plots as gp
from scripts.grouping.loop_recordings import collect_loop, has_loop
from scripts.grouping.scores import (
    TARGETS,
    compare_methods,
    meets_targets,
    score_groups,
    unscored,
)
from scripts.grouping.tables import comparison_table, grouping_table
from sim import dataset as ds
from sim.collect_worlds import label_space
from sim.runs import Runs

__all__ = ["TARGETS", "evaluate_grouping", "format_report", "main", "score_groups"]

JSON_FILE = "grouping.json"
LABELS_FILE = "groups.npz"  # per case and variant, the group of every frame (numpy .npz)


def group_scans(runs: Runs, poses: str) -> tuple[ObservationGraphPartitioner, dict]:
    """Fit the partitioner at default settings on ``runs`` with the poses ``poses``.

    Parameters
    ----------
    runs : Runs
        One world's recordings.
    poses : {"true", "odometry", "odometry+icp"}
        The poses to group with.

    Returns
    -------
    model : ObservationGraphPartitioner
        The fitted model.
    score : dict
        Its scores (None without ground truth), drift (None without true poses), time,
        whether it meets the targets and its number of arcs.
    """
    if poses == "true" and runs.poses is None:
        raise ValueError(f"{runs.world}: no true poses to group with (no ground truth)")
    model = ObservationGraphPartitioner(scan_matching=poses == "odometry+icp")
    given = runs.poses if poses == "true" else runs.odometry
    start = time.perf_counter()
    model.fit(runs.scans, given, groups=runs.groups)
    seconds = time.perf_counter() - start
    if runs.has_ground_truth:
        score = score_groups(runs.labels, model.labels_, runs.manifold_names)
        err = model.poses_[:, :2] - runs.poses[:, :2]
        drift, met = float(np.hypot(err[:, 0], err[:, 1]).max()), meets_targets(score)
    else:
        score = unscored(len(runs), model.labels_)
        drift = met = None
    score.update(
        poses=poses,
        max_drift_m=drift,
        seconds=seconds,
        meets_targets=met,
        arcs=len(model.topology_.arcs),
    )
    return model, score


def pose_variants(icp: Sequence[bool], true_poses: bool) -> list[str]:
    """Name the pose variants to group with.

    Parameters
    ----------
    icp : sequence of bool
        Odometry variants: raw odometry (False) and odometry refined by ICP (True).
    true_poses : bool
        Whether the true poses come first.

    Returns
    -------
    list of str
        ``"true"``, ``"odometry"`` and ``"odometry+icp"`` as asked.
    """
    names = ["true"] if true_poses else []
    return names + ["odometry+icp" if flag else "odometry" for flag in icp]


# --------------------------------------------------------------------------- the evaluation


def evaluate_grouping(
    dataset: ds.Dataset | str | os.PathLike,
    out_dir: str | os.PathLike,
    *,
    icp: Sequence[bool] = (False, True),
    true_poses: bool = True,
    loop: bool = True,
    loop_frames: int | None = None,
    compare: bool = True,
    figures: bool = True,
    progress: bool = True,
) -> dict:
    """Group each world's scans, score them, compare the methods, draw and save everything.

    Parameters
    ----------
    dataset : Dataset or path
        The dataset (``sim.dataset``); its sequences are grouped per world.
    out_dir : path
        Where ``grouping.json``, ``groups.npz`` (the group of every frame, per case and
        variant, and the drive index ``.../groups``), the figures and the loop sequences
        (``loop/``) go.
    icp : sequence of bool, default (False, True)
        Odometry variants to group: raw odometry (False) and odometry refined by ICP (True).
    true_poses : bool, default True
        Also group with the true poses (the upper bound the paper assumes: SLAM poses), when
        the dataset has them.
    loop : bool, default True
        Also drive and group a loop through each simulated world (collected once, cached in
        ``loop/``); skipped for a world that is not one of ours (an imported dataset).
    loop_frames : int, optional
        Frames of each loop; default: the dataset's frame spacing (``grouping_loop``).
    compare : bool, default True
        The four-way table (both sensors x both methods), on the dataset's sequences.
    figures : bool, default True
        Write the figures of the ICP (else odometry) grouping of each world and loop.
    progress : bool, default True
        Show a progress bar.

    Returns
    -------
    dict
        Everything written to ``grouping.json`` (see ``format_report`` for a summary).
    """
    from tqdm.auto import tqdm

    if not isinstance(dataset, ds.Dataset):
        dataset = ds.load_dataset(dataset)
    dataset.require("laser", "the observation grouping (group-eval)")  # before any output
    icp = tuple(bool(flag) for flag in icp)
    true_poses = true_poses and dataset.has_ground_truth  # imported logs have none
    if not icp and not true_poses:
        raise ValueError("nothing to group: icp is empty and there are no true poses")
    out_dir = Path(out_dir)
    out_dir.mkdir(parents=True, exist_ok=True)
    variants = pose_variants(icp, true_poses)
    shown = "odometry+icp" if True in icp else variants[-1]  # the grouping drawn and compared
    worlds = dataset.worlds
    # a loop is driven in the simulated world: not for a dataset imported from a robot's log
    simulated = dataset.has_ground_truth
    loops = [w for w in worlds if has_loop(w) and simulated] if loop else []
    steps = len(worlds) * (len(variants) + compare + figures) + len(loops) * (
        len(variants) + figures
    )
    bar = tqdm(total=steps, desc="group-eval", unit="step", disable=not progress)
    result = {
        "dataset": str(dataset.path),
        "settings": {
            "partitioner": "ObservationGraphPartitioner() defaults (threshold 1, delta 0.1 m, "
            "assoc mrpt, normalized Laplacian); ICP = scan_matching=True",
            "runs": "each world's sequences grouped together; groups = the drive of each frame",
            "targets": TARGETS,
            "image_features": "ColorHistogramFeatures() (HSV 8x4x4 in 2x2 cells)",
            "image_graph": "knn_gaussian_affinity: k = ceil(sqrt(n)), sigma = median distance "
            "to the k-th neighbour",
            "manifold_clustering": "K = manifolds of the world (without ground truth: groups "
            "of the scan partition), Q = min(35, n // (2K))",
            "shown": shown,
            "cpu_count": os.cpu_count(),
        },
        "ground_truth": dataset.has_ground_truth,
        "default": {},
        "loop": {},
        "compare": {},
        "figures": [],
        "labels_file": LABELS_FILE,
    }
    labels = {}  # "section/world/variant" -> one group label per frame (LABELS_FILE)
    start = time.perf_counter()
    try:
        for world in worlds:
            cases = [("default", world, dataset.runs(world))]
            if world in loops:
                bar.set_postfix_str(f"collect {world} loop")
                seq = collect_loop(world, out_dir / "loop", frames=loop_frames)
                loop_runs = Runs.from_sequences([seq], dataset.max_range, label_space((world,)))
                cases.append(("loop", f"{world}-loop", loop_runs))
            for section, tag, runs in cases:
                result[section][world] = {"frames": len(runs), "sequences": runs.names}
                labels[f"{section}/{world}/groups"] = runs.groups
                for variant in variants:
                    bar.set_postfix_str(f"{tag} {variant}")
                    model, score = group_scans(runs, variant)
                    result[section][world][variant] = score
                    labels[f"{section}/{world}/{variant}"] = model.labels_
                    bar.update()
                    if variant != shown:
                        continue
                    if figures:
                        paths = gp.write_figures(out_dir, tag, runs, model)
                        result["figures"] += [p.name for p in paths]
                        bar.update()
                    if compare and section == "default":
                        bar.set_postfix_str(f"{world}: four-way comparison")
                        rows = compare_methods(runs, model, score)
                        for name, row in rows.items():
                            labels[f"compare/{world}/{name}"] = row.pop("labels")
                        result["compare"][world] = rows
                        bar.update()
    finally:
        bar.close()
    result["seconds"] = time.perf_counter() - start
    result["targets_met"] = {
        f"{section}/{world}/{variant}": result[section][world][variant]["meets_targets"]
        for section in ("default", "loop")
        for world in result[section]
        for variant in variants
        if result[section][world][variant]["meets_targets"] is not None
    }
    ds.write_sequence(out_dir / LABELS_FILE, {k: np.asarray(v) for k, v in labels.items()})
    write_json(out_dir / JSON_FILE, result)
    return result


# --------------------------------------------------------------------------- report


def format_report(result: dict) -> str:
    """Format markdown tables of the groupings and of the four-way comparison.

    They are those of ``scripts.grouping.tables``, the same tables the HTML report shows.

    Parameters
    ----------
    result : dict
        The result of ``evaluate_grouping``.

    Returns
    -------
    str
        The markdown.
    """
    tables = [grouping_table(result)]
    if result["compare"]:
        tables.append(comparison_table(result))
    return "\n".join(t.to_markdown() for t in tables)


def build_parser(parser: argparse.ArgumentParser | None = None) -> argparse.ArgumentParser:
    """Build the command line (shared with ``topomap group-eval``).

    Parameters
    ----------
    parser : argparse.ArgumentParser, optional
        The parser to add the arguments to; a new one by default.

    Returns
    -------
    argparse.ArgumentParser
        The parser.
    """
    p = parser or argparse.ArgumentParser(description=__doc__.splitlines()[0])
    source = p.add_mutually_exclusive_group(required=True)
    source.add_argument(
        "--data", action="append", help="dataset directory (repeat for several with --method)"
    )
    source.add_argument(
        "--carmen",
        action="append",
        metavar="LOG",
        help="a Carmen laser log (.log or .log.gz; repeat for several) to group instead of a "
        "dataset (scripts.grouping.carmen_logs)",
    )
    p.add_argument("--out", required=True, help="output directory (JSON, figures, loops)")
    p.add_argument("--json", action="store_true", help="print the JSON instead of the tables")
    p.add_argument("--no-loop", action="store_true", help="skip the loop through each world")
    p.add_argument("--loop-frames", type=int, default=None, help="frames of each loop")
    p.add_argument("--quiet", action="store_true", help="no progress bar")
    p.add_argument(
        "--local-maps",
        action="store_true",
        help="test the local maps' consistency against submap baselines "
        "(scripts.grouping.local_maps)",
    )
    from scripts.grouping.outside import add_arguments

    add_arguments(p)
    return p


def one_dataset(args) -> None:
    """Make ``args.data`` the one dataset the built-in evaluations read.

    Several datasets are allowed only with ``--method``; ``args`` is changed in place.

    Parameters
    ----------
    args : argparse.Namespace
        The parsed command line, with ``data``.

    Raises
    ------
    ValueError
        When ``--data`` is given more than once.
    """
    if isinstance(args.data, list):
        if len(args.data) > 1:
            raise ValueError("--data is given once, except with --method")
        args.data = args.data[0]


def run(args) -> int:
    """Run ``topomap group-eval`` on the parsed command line.

    With ``--method`` the outside method is evaluated, with ``--local-maps`` the local
    maps, else the grouping.

    Parameters
    ----------
    args : argparse.Namespace
        The command line of ``build_parser``.

    Returns
    -------
    int
        The exit status.
    """
    if getattr(args, "method", None):
        from scripts.grouping.outside import run as run_method

        return run_method(args)
    one_dataset(args)
    if getattr(args, "local_maps", False):
        from scripts.grouping import local_maps as eval_local_maps

        return eval_local_maps.run(args)
    result = evaluate_grouping(
        args.data,
        args.out,
        loop=not args.no_loop,
        loop_frames=args.loop_frames,
        progress=not args.quiet,
    )
    if args.json:
        print(json.dumps(jsonable(result), indent=2))
    else:
        print(format_report(result))
        print(
            f"\nwrote {Path(args.out) / JSON_FILE}, {Path(args.out) / LABELS_FILE} and "
            f"{len(result['figures'])} figures"
        )
    return 0


def main(argv: list[str] | None = None) -> int:
    """Run the command line ``python -m scripts.grouping.evaluate``.

    Parameters
    ----------
    argv : list of str, optional
        The arguments; ``sys.argv[1:]`` by default.

    Returns
    -------
    int
        The exit status.
    """
    import sim  # noqa: F401  (chooses the headless GL backend before mujoco loads)

    return run(build_parser().parse_args(argv))


if __name__ == "__main__":
    raise SystemExit(main())
