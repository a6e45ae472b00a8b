"""The grouping's knobs measured, not assumed.

    python -m experiments.grouping.knobs [--data DIR] [--carmen LOG ...] --out DIR

One knob at a time is moved away from the defaults of
[`mapping.ObservationGraphPartitioner`][mapping.grouping.partitioner.ObservationGraphPartitioner]
(Blanco et al.):

* ``match_distance``, the tolerance ``delta`` of eq. 16 (0.1 m is below the beam spacing of a
  1-degree laser beyond about 6 m, of a half-degree one beyond about 11 m);
* ``range_cap``: returns beyond it are left out of the overlap (long returns are sparse, so
  they rarely match within ``delta``, yet they count in the denominator of eq. 17);
* ``fov``: the field of view the overlap sees; 360 degrees is re-scanned in the simulator at
  the true poses, narrower views are cut from the recorded 180 degrees (the real logs have
  180 degrees only, so their 360 cell is empty);
* ``threshold``: the Ncut below which a bisection is accepted (eq. 12-13; the paper's 1).

The knob acts on the *grouping* only: each group's local map is rebuilt and scored from the
full recorded scans (``scripts.grouping.local_maps.score_submaps``), so that a row measures the
groups, not a poorer sensor. Every case uses its true poses (worlds: the simulator's; logs:
the corrected SLAM poses), ICP off, every 5th scan held out.

Scores: on the worlds purity and ARI against the manifolds, and on every case the share of
held-out scans that localise against their group's local map (Wilson 95 % interval). The
estimator's own knobs (``match_distance``, ``threshold``) are chosen jointly on the ``dev``
cases (the dataset's hallway and ACES; `dev_score`): the best hallway ARI over their
grid, among settings that keep ACES' localisation rate within the defaults' interval, and
only if it beats the defaults by ``MIN_GAIN``. The ``test`` cases (the lawn, CSAIL) are
scored, never used to choose. Field of view and range cap are the sensor's, not the
estimator's: they are measured and reported, not chosen.
"""

from __future__ import annotations

import os
import time
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from mapping.grouping.partitioner import ObservationGraphPartitioner
from mapping.metrics import adjusted_rand_index, purity
from scripts.grouping.local_maps import score_submaps, split

__all__ = [
    "DEFAULTS",
    "JSON_FILE",
    "KNOBS",
    "Case",
    "crop",
    "dev_score",
    "evaluate_knobs",
    "format_report",
]

JSON_FILE = "knobs.json"
DEFAULTS = {"match_distance": 0.1, "range_cap": None, "fov_deg": 180, "threshold": 1.0}
KNOBS: dict[str, tuple] = {
    "match_distance": (0.05, 0.1, 0.2, 0.3),
    "range_cap": (None, 10.0, 5.0),
    "fov_deg": (90, 180, 360),
    "threshold": (0.6, 0.8, 1.0, 1.2),
}
MIN_GAIN = 0.02  # a knob leaves its default only for a dev score this much higher


@dataclass(frozen=True)
class Case:
    """One sequence set to group: points per scan (sensor frame), true poses, drives.

    ``scans_360``: the same poses scanned over 360 degrees (worlds only); ``labels``: the
    manifold of each scan (worlds only); ``role``: ``"dev"`` or ``"test"``.
    """

    name: str
    role: str
    scans: list
    poses: np.ndarray
    groups: np.ndarray
    labels: np.ndarray | None = None
    scans_360: list | None = None


def crop(points: np.ndarray, *, fov_deg: float = 180.0, range_cap: float | None = None):
    """The returns of one scan within ``fov_deg`` about the heading and below ``range_cap``."""
    keep = np.abs(np.arctan2(points[:, 1], points[:, 0])) <= np.deg2rad(fov_deg) / 2 + 1e-9
    if range_cap is not None:
        keep &= np.hypot(points[:, 0], points[:, 1]) < range_cap
    return points[keep]


def _grouping_input(case: Case, setting: dict) -> list | None:
    fov = setting["fov_deg"]
    if fov > 180:
        if case.scans_360 is None:
            return None  # the recording has no wider view
        source, fov = case.scans_360, 360.0
    else:
        source = case.scans
    return [crop(s, fov_deg=fov, range_cap=setting["range_cap"]) for s in source]


def settings() -> list[tuple[str, object, dict]]:
    """``(knob, value, full setting)``: the defaults, then each knob moved alone."""
    out = [("defaults", None, dict(DEFAULTS))]
    for knob, values in KNOBS.items():
        for value in values:
            if value != DEFAULTS[knob]:
                out.append((knob, value, {**DEFAULTS, knob: value}))
    return out


def score_setting(case: Case, setting: dict, rng: np.random.Generator) -> dict | None:
    """Group ``case``'s training scans under ``setting`` and score the groups (None: n/a)."""
    scans = _grouping_input(case, setting)
    if scans is None:
        return None
    train, _, _ = split(case.groups, 5)
    model = ObservationGraphPartitioner(
        threshold=setting["threshold"],
        match_distance=setting["match_distance"],
        scan_matching=False,
    )
    start = time.perf_counter()
    model.fit([scans[i] for i in train], case.poses[train], groups=case.groups[train])
    seconds = time.perf_counter() - start
    out = {"groups": int(model.n_groups_), "seconds": seconds}
    if case.labels is not None:
        truth = case.labels[train]
        out["purity"] = float(purity(truth, model.labels_))
        out["ari"] = float(adjusted_rand_index(truth, model.labels_))
    out.update(score_submaps(case.scans, case.poses, case.poses, case.groups, model.labels_, rng))
    return out


def dev_score(rows: dict, floors: dict[str, float]) -> float:
    """The selection criterion: mean ARI over the dev worlds, or ``-inf`` where a dev log's
    held-out localisation rate falls below its floor (``floors``: log -> rate).

    ARI is the measure where labels exist; the localisation rate alone would reward ever
    smaller groups (a submap of a few scans localises its neighbours well), so on the
    unlabelled logs it only guards against a setting that makes the local maps worse.
    """
    aris = []
    for name, r in rows.items():
        s = r["score"]
        if r["role"] != "dev" or s is None:
            continue
        if "ari" in s:
            aris.append(s["ari"])
        elif s["localisation"]["rate"] < floors.get(name, -np.inf):
            return -np.inf
    return float(np.mean(aris)) if aris else float("nan")


def floors_of(rows: dict) -> dict[str, float]:
    """Each dev log's floor: the lower end of the defaults' Wilson 95 % interval."""
    return {
        name: r["score"]["localisation"]["rate_ci95"][0]
        for name, r in rows.items()
        if r["role"] == "dev" and r["score"] is not None and "ari" not in r["score"]
    }


def _evaluate(cases: list[Case], setting: dict, seed: int) -> dict:
    # a fresh generator per cell: a cell's numbers do not depend on which cells ran before
    return {
        c.name: {"role": c.role, "score": score_setting(c, setting, np.random.default_rng(seed))}
        for c in cases
    }


def evaluate_knobs(cases: list[Case], out_dir, *, seed: int = 0, progress: bool = True) -> dict:
    """Sweep each knob alone on every case, choose ``match_distance`` and ``threshold``
    jointly on the dev cases (grid of `KNOBS`), then score the choice on every case.
    Writes ``knobs.json``."""
    from tqdm.auto import tqdm

    from common.fileio import write_json

    names = [c.name for c in cases]
    if len(set(names)) != len(names):
        raise ValueError(f"cases must have distinct names, got {names}")
    dev = [c for c in cases if c.role == "dev"]
    result = {
        "defaults": DEFAULTS,
        "knobs": {k: list(v) for k, v in KNOBS.items()},
        "cases": {c.name: c.role for c in cases},
        "seed": seed,
        "cpu_count": os.cpu_count(),
        "settings": {},
        "dev_grid": [],
    }
    todo = settings()
    grid = [
        {**DEFAULTS, "match_distance": m, "threshold": t}
        for m in KNOBS["match_distance"]
        for t in KNOBS["threshold"]
    ]
    bar = tqdm(total=len(todo) + len(grid) + 1, desc="grouping knobs", disable=not progress)
    try:
        for knob, value, setting in todo:
            bar.set_postfix_str(f"{knob}={value}")
            rows = _evaluate(cases, setting, seed)
            key = "defaults" if knob == "defaults" else f"{knob}={value}"
            result["settings"][key] = {"knob": knob, "value": value, "setting": setting}
            result["settings"][key]["rows"] = rows
            bar.update()
        floors = floors_of(result["settings"]["defaults"]["rows"])
        for entry in result["settings"].values():
            entry["dev_score"] = dev_score(entry["rows"], floors)
        best, best_score = dict(DEFAULTS), result["settings"]["defaults"]["dev_score"]
        for setting in grid:
            bar.set_postfix_str(f"dev grid {setting['match_distance']}, {setting['threshold']}")
            score = dev_score(_evaluate(dev, setting, seed), floors)
            result["dev_grid"].append({"setting": setting, "dev_score": score})
            if score > best_score + MIN_GAIN:
                best, best_score = setting, score
            bar.update()
        result["chosen"] = best
        rows = _evaluate(cases, best, seed)
        result["settings"]["chosen"] = {"knob": "chosen", "value": None, "setting": best}
        result["settings"]["chosen"].update(rows=rows, dev_score=dev_score(rows, floors))
        bar.update()
    finally:
        bar.close()
    out_dir = Path(out_dir)
    out_dir.mkdir(parents=True, exist_ok=True)
    write_json(out_dir / JSON_FILE, result)
    return result


def _cell(score: dict | None) -> str:
    if score is None:
        return "n/a"
    loc = score["localisation"]
    lo, hi = loc["rate_ci95"] or (float("nan"), float("nan"))
    ari = f"ARI {score['ari']:+.2f}, " if "ari" in score else ""
    return f"{score['groups']} g, {ari}{loc['localised']}/{loc['held_out']} ({lo:.2f}-{hi:.2f})"


def format_report(result: dict) -> str:
    """One markdown row per setting: dev score, then each case's groups, ARI, localised."""
    names = list(result["cases"])
    header = [f"{n} ({result['cases'][n]})" for n in names]
    lines = [
        "| setting | dev score | " + " | ".join(header) + " |",
        "|---|---|" + "---|" * len(names),
    ]
    for key, entry in result["settings"].items():
        cells = [_cell(entry["rows"][n]["score"]) for n in names]
        lines.append(f"| {key} | {entry['dev_score']:.3f} | " + " | ".join(cells) + " |")
    lines.append("")
    lines.append(f"chosen on dev (match_distance x threshold grid): {result['chosen']}")
    return "\n".join(lines)


def world_cases(data, roles: dict[str, str], suffix: str = "") -> list[Case]:
    """The worlds of a dataset with ground truth, each also re-scanned over 360 degrees;
    a case is named after its world plus ``suffix``, and ``roles`` maps names to roles."""
    from sim import dataset as ds

    dataset = data if isinstance(data, ds.Dataset) else ds.load_dataset(data)
    if not dataset.has_ground_truth:
        raise ValueError(f"{dataset.path}: the knob sweep needs true poses and manifold labels")
    if dataset.meta.get("settings", {}).get("randomize", False):
        # the 360-degree scans are taken in the canonical world, which a randomised
        # dataset's clutter does not match
        raise ValueError(f"{dataset.path}: the knob sweep needs a dataset without --randomize")
    cases = []
    for world in dataset.worlds:
        runs = dataset.runs(world)
        wide = rescan_360(world, runs.poses, dataset.max_range)
        name = world + suffix
        role = roles.get(name, "test")
        cases.append(Case(name, role, runs.scans, runs.poses, runs.groups, runs.labels, wide))
    return cases


def rescan_360(world_name: str, poses: np.ndarray, max_range: float | None) -> list:
    """The scans a 360-degree, 720-beam laser takes at ``poses`` in the canonical world."""
    from common.geometry import scan_to_points
    from scenes import build_world
    from sim.laser import LaserConfig
    from sim.odometry import OdometryConfig
    from sim.simulator import Simulator

    # the recorded laser's half-degree beams and noise, all the way round
    config = LaserConfig(fov=2 * np.pi, beams=720, max_range=max_range or 20.0)
    sim = Simulator(build_world(world_name), None, config, OdometryConfig())
    rng = np.random.default_rng(0)
    try:
        out = []
        for pose in poses:
            sim.reset(pose, rng)
            out.append(scan_to_points(sim.scan(rng), config.angles, config.max_range))
        return out
    finally:
        sim.close()


def carmen_cases(paths, roles: dict[str, str]) -> list[Case]:
    """Carmen logs with their corrected poses (180 degrees: no 360 re-scan)."""
    from scripts.grouping.carmen_logs import log_points
    from sim.readers.carmen import read_carmen

    cases = []
    for path in paths:
        log = read_carmen(path)
        tag = log.path.name.split(".")[0]
        groups = np.zeros(len(log), dtype=int)
        cases.append(Case(tag, roles.get(tag, "test"), log_points(log), log.poses, groups))
    return cases


DEV = {"hallway": "dev", "aces-corrected": "dev"}


def main(argv: list[str] | None = None) -> int:
    """``python -m experiments.grouping.knobs [--data DIR] [--carmen LOG ...] --out DIR``."""
    import argparse
    import json

    import sim  # noqa: F401  (chooses the headless GL backend before mujoco loads)

    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument(
        "--data",
        action="append",
        default=[],
        metavar="DIR",
        help="a dataset with ground truth; repeat for several (the first one's hallway is dev, "
        "the others are test, named by their seed)",
    )
    p.add_argument("--carmen", action="append", default=[], metavar="LOG", help="a Carmen log")
    p.add_argument("--out", required=True, help="output directory (knobs.json)")
    p.add_argument("--json", action="store_true", help="print the JSON instead of the table")
    p.add_argument("--quiet", action="store_true", help="no progress bar")
    args = p.parse_args(argv)
    if not args.data and not args.carmen:
        p.error("give --data DIR and/or --carmen LOG")
    from sim.dataset import load_dataset

    cases = []
    for k, path in enumerate(args.data):
        data = load_dataset(path)
        suffix = "" if k == 0 else f" seed {data.meta.get('settings', {}).get('seed', k)}"
        cases += world_cases(data, DEV, suffix)
    cases += carmen_cases(args.carmen, DEV)
    result = evaluate_knobs(cases, args.out, progress=not args.quiet)
    print(json.dumps(result, indent=2, default=str) if args.json else format_report(result))
    if not args.json:
        print(f"\nwrote {Path(args.out) / JSON_FILE}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
