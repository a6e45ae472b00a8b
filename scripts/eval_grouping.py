"""Evaluate the laser observation grouping (Blanco et al.) on the simulated worlds.

    python -m scripts.eval_grouping --data out/dataset --out out/grouping [--json]
    topomap group-eval --data out/dataset --out out/grouping [--json]

For each world, the default dataset's three sequences (main manifold, then one branch each) are
grouped together in one observation graph (``groups``: the drive each frame belongs to), with
the noisy odometry poses, without and with ICP refinement, and with the true poses as a
reference. A longer loop through each world (main -> every branch, back to the junction between
them; ``scripts.grouping_loop``) is grouped the same way. Groups are scored against the
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
from mapping.features import ColorHistogramFeatures, ScanFeatures
from mapping.manifold import ManifoldClustering
from mapping.metrics import adjusted_rand_index, contingency_matrix, purity
from mapping.partition import ObservationGraphPartitioner
from mapping.similarity import default_n_neighbors, knn_gaussian_affinity
from scenes import MANIFOLDS, WORLDS
from scripts import grouping_plots as gp
from scripts.grouping_loop import collect_loop
from sim import dataset as ds
from sim.runs import Runs

__all__ = ["TARGETS", "evaluate_grouping", "format_report", "main", "score_groups"]

# The issue's targets: groups mix manifolds by at most 10 %, no manifold in more than 3 groups.
TARGETS = {"purity_min": 0.9, "max_groups_per_manifold": 3}
MC_MIN_CLUSTER_SIZE = 35  # Q of docs/manifold-clustering.md on the same sequences
JSON_FILE = "grouping.json"
NO_LABELS = "no ground-truth labels: groups are not scored (purity, ARI, drift and targets: --)"
LABELS_FILE = "groups.npz"  # per case and variant, the group of every frame (numpy .npz)


# --------------------------------------------------------------------------- scoring


def score_groups(truth: np.ndarray, labels: np.ndarray) -> dict:
    """Groups against ground-truth manifold ids (frames on no manifold, -1, are left out).

    ``groups_per_manifold``: for each manifold, the groups whose majority manifold it is (every
    group counts for exactly one manifold; frames of a group that belong elsewhere are what
    ``purity`` charges). ``groups_touching``: the stricter count of groups holding any frame of
    the manifold, which also counts a group that takes a few frames across a boundary.
    """
    truth = np.asarray(truth, dtype=int)
    labels = np.asarray(labels, dtype=int)
    on = truth >= 0
    truth, labels = truth[on], labels[on]
    manifolds = np.unique(truth)
    groups = np.unique(labels)
    # The contingency matrix purity is computed from: rows manifolds, columns groups.
    majority = manifolds[contingency_matrix(truth, labels).argmax(axis=0)]
    per = {MANIFOLDS[m]: int(np.sum(majority == m)) for m in manifolds}
    touching = {MANIFOLDS[m]: len(np.unique(labels[truth == m])) for m in manifolds}
    return {
        "frames": int(on.sum()),
        "groups": len(groups),
        "purity": purity(truth, labels),
        "ari": adjusted_rand_index(truth, labels),
        "groups_per_manifold": per,
        "max_groups_per_manifold": max(per.values()),
        "groups_touching": touching,
        "max_groups_touching": max(touching.values()),
    }


def meets_targets(score: dict) -> bool:
    return (
        score["purity"] >= TARGETS["purity_min"]
        and score["max_groups_per_manifold"] <= TARGETS["max_groups_per_manifold"]
    )


# --------------------------------------------------------------------------- grouping


def group_scans(runs: Runs, poses: str) -> tuple[ObservationGraphPartitioner, dict]:
    """The partitioner at default settings on ``runs`` with ``poses`` in {"true", "odometry",
    "odometry+icp"}; returns the fitted model and its scores (None without ground truth),
    drift (None without true poses) and time."""
    if poses == "true" and runs.poses is None:
        raise ValueError(f"{runs.world}: no true poses to group with (no ground truth)")
    model = ObservationGraphPartitioner(scan_matching=poses == "odometry+icp")
    given = runs.poses if poses == "true" else runs.odometry
    start = time.perf_counter()
    model.fit(runs.scans, given, groups=runs.groups)
    seconds = time.perf_counter() - start
    if runs.has_ground_truth:
        score = score_groups(runs.labels, model.labels_)
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


def unscored(frames: int, labels: np.ndarray) -> dict:
    """The keys of :func:`score_groups` for groups that cannot be scored (no ground truth):
    the counts, and None for every score."""
    keys = ("purity", "ari", "max_groups_per_manifold", "max_groups_touching")
    return {
        "frames": frames,
        "groups": len(np.unique(labels)),
        **dict.fromkeys(keys),
        "groups_per_manifold": {},
        "groups_touching": {},
        "scored": "no ground-truth labels",
    }


def pose_variants(icp: Sequence[bool], true_poses: bool) -> list[str]:
    names = ["true"] if true_poses else []
    return names + ["odometry+icp" if flag else "odometry" for flag in icp]


def compare_methods(runs: Runs, scan_model: ObservationGraphPartitioner, scan_score: dict):
    """Both sensors x both methods on one world (the four-way table).

    - partition x scans: ``scan_model`` (already fitted; its pose variant is recorded).
    - partition x images: ``affinity="precomputed"`` on ``knn_gaussian_affinity`` of the images
      (k = ceil(sqrt(n)) neighbours, sigma = median k-th-neighbour distance).
    - manifold clustering x scans / images: ``ManifoldClustering(K, Q)`` with K the number of
      ground-truth manifolds of the world (without ground truth: the number of groups the scan
      partition found) and Q = min(35, n // (2K)).

    Each entry holds its ``labels`` (one per frame) beside the scores.
    """

    def score(labels):
        if runs.has_ground_truth:
            return score_groups(runs.labels, labels)
        return unscored(len(runs), labels)

    out = {
        "partition/scans": {
            **_brief(scan_score),
            "poses": scan_score["poses"],
            "labels": scan_model.labels_,
        }
    }
    # The image features that reproduce the paper's image result (docs/manifold-clustering.md).
    images = ColorHistogramFeatures().fit_transform(runs.images)
    start = time.perf_counter()
    W, sigma = knn_gaussian_affinity(images)
    labels = ObservationGraphPartitioner(affinity="precomputed").fit(W).labels_
    out["partition/images"] = {
        **_brief(score(labels), time.perf_counter() - start),
        "n_neighbors": default_n_neighbors(len(runs)),
        "sigma": sigma,
        "labels": labels,
    }
    features = {
        "scans": ScanFeatures(max_range=runs.max_range).fit_transform(runs.ranges),
        "images": images,
    }
    if runs.has_ground_truth:
        k = len(np.unique(runs.labels[runs.labels >= 0]))
    else:
        k = scan_model.n_groups_
    q = max(1, min(MC_MIN_CLUSTER_SIZE, len(runs) // (2 * k)))
    for sensor, X in features.items():
        start = time.perf_counter()
        labels = ManifoldClustering(n_clusters=k, min_cluster_size=q).fit(X).labels_
        out[f"manifold/{sensor}"] = {
            **_brief(score(labels), time.perf_counter() - start),
            "K": k,
            "Q": q,
            "labels": labels,
        }
    return out


def _brief(score: dict, seconds: float | None = None) -> dict:
    keys = ("groups", "purity", "ari", "max_groups_per_manifold", "groups_per_manifold")
    out = {k: score[k] for k in keys}
    out["seconds"] = score.get("seconds") if seconds is None else seconds
    return out


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
    loops = [w for w in worlds if w in WORLDS and simulated] if loop else []
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
                cases.append(
                    ("loop", f"{world}-loop", Runs.from_sequences([seq], dataset.max_range))
                )
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


def _cell(value, spec: str) -> str:
    return "--" if value is None else format(value, spec)


def format_report(result: dict) -> str:
    """Markdown tables of the groupings and of the four-way comparison."""
    lines = [] if result.get("ground_truth", True) else [NO_LABELS, ""]
    lines += [
        "| case | poses | frames | groups | purity | ARI | groups per manifold (majority) "
        "| max touching | drift (m) | time (s) | targets |",
        "|---|---|---|---|---|---|---|---|---|---|---|",
    ]
    for section in ("default", "loop"):
        for world, entry in result[section].items():
            for variant, s in entry.items():
                if not isinstance(s, dict):
                    continue
                per = " / ".join(str(v) for v in s["groups_per_manifold"].values()) or "--"
                met = {True: "met", False: "missed", None: "--"}[s["meets_targets"]]
                lines.append(
                    f"| {world}{'-loop' if section == 'loop' else ''} | {variant} | {s['frames']} "
                    f"| {s['groups']} | {_cell(s['purity'], '.3f')} | {_cell(s['ari'], '+.3f')} "
                    f"| {per} | {_cell(s['max_groups_touching'], 'd')} "
                    f"| {_cell(s['max_drift_m'], '.2f')} | {s['seconds']:.2f} | {met} |"
                )
    if result["compare"]:
        lines += [
            "",
            "| world | method / sensor | groups | purity | ARI | max groups per manifold "
            "| time (s) |",
            "|---|---|---|---|---|---|---|",
        ]
        for world, rows in result["compare"].items():
            for name, s in rows.items():
                lines.append(
                    f"| {world} | {name} | {s['groups']} | {_cell(s['purity'], '.3f')} "
                    f"| {_cell(s['ari'], '+.3f')} | {_cell(s['max_groups_per_manifold'], 'd')} "
                    f"| {s['seconds']:.2f} |"
                )
    return "\n".join(lines)


def build_parser(parser: argparse.ArgumentParser | None = None) -> argparse.ArgumentParser:
    """The command line (shared with ``topomap group-eval``)."""
    p = parser or argparse.ArgumentParser(description=__doc__.splitlines()[0])
    source = p.add_mutually_exclusive_group(required=True)
    source.add_argument("--data", help="dataset directory")
    source.add_argument(
        "--carmen",
        action="append",
        metavar="LOG",
        help="a Carmen laser log (.log or .log.gz; repeat for several) to group instead of a "
        "dataset (scripts.eval_carmen)",
    )
    p.add_argument("--out", required=True, help="output directory (JSON, figures, loops)")
    p.add_argument("--json", action="store_true", help="print the JSON instead of the tables")
    p.add_argument("--no-loop", action="store_true", help="skip the loop through each world")
    p.add_argument("--loop-frames", type=int, default=None, help="frames of each loop")
    p.add_argument("--quiet", action="store_true", help="no progress bar")
    p.add_argument(
        "--local-maps",
        action="store_true",
        help="test the local maps' consistency against submap baselines (scripts.eval_local_maps)",
    )
    return p


def run(args) -> int:
    if getattr(args, "local_maps", False):
        from scripts import eval_local_maps

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
    import sim  # noqa: F401  (chooses the headless GL backend before mujoco loads)

    return run(build_parser().parse_args(argv))


if __name__ == "__main__":
    raise SystemExit(main())
