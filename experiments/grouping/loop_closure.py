"""What closing the loop changes: the loops of
``scripts.grouping.loop_recordings``.

    python -m experiments.grouping.loop_closure (--data DIR | --carmen LOG [--carmen LOG]) --out DIR

For each world's loop: absolute trajectory error of the raw odometry, of sequential ICP
(chained) and of the GTSAM pose graph with verified loop closures (``mapping.grouping.pose_graph``),
and the grouping (``ObservationGraphPartitioner(scan_matching=False)``) on each of these poses
and on the true ones, scored against the ground-truth manifolds (``score_groups``).
Writes ``loop_closure.json``.

With ``--carmen``, each real log instead: the log carries only the corrected (SLAM) poses, no
raw odometry, so odometry is simulated from them with ``sim.odometry``'s default noise (seed
0, as ``scripts.grouping.local_maps`` does) and the corrected poses are the truth; the logs have
no manifold labels, so the grouping is reported by its number of groups only.
"""

from __future__ import annotations

import argparse
from pathlib import Path

from common.fileio import write_json
from mapping.grouping.partitioner import ObservationGraphPartitioner
from mapping.grouping.pose_graph import absolute_trajectory_error, close_loops
from scripts.grouping.evaluate import score_groups
from scripts.grouping.loop_recordings import collect_loop
from sim import dataset as ds
from sim.collect_worlds import label_space
from sim.runs import Runs

JSON_FILE = "loop_closure.json"


def evaluate(data, out_dir) -> dict:
    dataset = ds.load_dataset(data)
    result = {}
    for world in dataset.worlds:
        seq = collect_loop(world, Path(out_dir) / "loop")
        r = Runs.from_sequences([seq], dataset.max_range, label_space((world,)))
        lc = close_loops(r.scans, r.odometry, groups=r.groups)
        rows = {"loops": len(lc.loops), "candidates": lc.candidates}
        for name, poses in (
            ("true", r.poses),
            ("odometry", r.odometry),
            ("odometry+icp", lc.chained),
            ("odometry+icp+loop closure", lc.poses),
        ):
            model = ObservationGraphPartitioner(scan_matching=False).fit(r.scans, poses)
            rows[name] = {
                "ate": absolute_trajectory_error(poses, r.poses),
                "grouping": score_groups(r.labels, model.labels_, r.manifold_names),
            }
        result[f"{world} loop"] = rows
    write_json(Path(out_dir) / JSON_FILE, result)
    return result


def evaluate_carmen(paths, out_dir) -> dict:
    """Loop closure on real logs with odometry simulated from their corrected poses."""
    from scripts.grouping.carmen_logs import log_points
    from scripts.grouping.local_maps import simulated_odometry
    from sim.readers.carmen import read_carmen

    result = {}
    for path in paths:
        log = read_carmen(path)
        scans, truth = log_points(log), log.poses
        odometry = simulated_odometry(truth)
        lc = close_loops(scans, odometry)
        rows = {"loops": len(lc.loops), "candidates": lc.candidates}
        for name, poses in (
            ("corrected (truth)", truth),
            ("odometry", odometry),
            ("odometry+icp", lc.chained),
            ("odometry+icp+loop closure", lc.poses),
        ):
            model = ObservationGraphPartitioner(scan_matching=False).fit(scans, poses)
            rows[name] = {
                "ate": absolute_trajectory_error(poses, truth),
                "grouping": {"groups": int(model.n_groups_)},
            }
        result[log.path.name.split(".")[0]] = rows
    Path(out_dir).mkdir(parents=True, exist_ok=True)
    write_json(Path(out_dir) / JSON_FILE, result)
    return result


def format_report(result: dict) -> str:
    lines = [
        "| loop | poses | ATE rmse / max (m) | heading rmse (deg) | groups | purity | ARI "
        "| groups per manifold |",
        "|---|---|---|---|---|---|---|---|",
    ]
    for world, rows in result.items():
        for name, row in rows.items():
            if not isinstance(row, dict):
                continue
            a, g = row["ate"], row["grouping"]
            per = " / ".join(str(v) for v in g.get("groups_per_manifold", {}).values()) or "--"
            purity = f"{g['purity']:.3f}" if "purity" in g else "--"
            ari = f"{g['ari']:+.3f}" if "ari" in g else "--"
            lines.append(
                f"| {world} | {name} | {a['rmse_m']:.2f} / {a['max_m']:.2f} "
                f"| {a['heading_rmse_deg']:.1f} | {g['groups']} | {purity} | {ari} | {per} |"
            )
        lines.append(
            f"| {world} | loop closures accepted / candidates "
            f"| {rows['loops']} / {rows['candidates']} | | | | | |"
        )
    return "\n".join(lines)


def main(argv=None) -> int:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    source = p.add_mutually_exclusive_group(required=True)
    source.add_argument("--data", help="a dataset with ground truth (the worlds' loops)")
    source.add_argument("--carmen", action="append", metavar="LOG", help="a Carmen log")
    p.add_argument("--out", required=True)
    args = p.parse_args(argv)
    if args.carmen:
        print(format_report(evaluate_carmen(args.carmen, args.out)))
    else:
        print(format_report(evaluate(args.data, args.out)))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
