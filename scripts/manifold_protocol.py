"""A frozen evaluation protocol for manifold clustering on the image datasets (issue 13).

Every choice (features: HSV histograms 8x4x4 in 2x2 cells; merge rule ``separability``; K = 8,
Q = 35; the baselines' label-free rules) was made on the ``dev`` dataset, seed 0, the one
``docs/manifold-clustering.md`` was written on. This script applies them unchanged to fresh
dataset seeds and reports every method's error per seed and as a mean with a bootstrap 95%
interval over seeds. Conditions (``CONDITIONS``):

* ``interleaved``: even frames of each sequence build the map, odd frames test it (the paper's
  split; test frames lie ~0.1 m from training frames);
* ``held-out``: the map from seed S's even frames, the test frames are the odd frames of seed
  S+1's drives (another traversal of the same worlds, other teleop jitter);
* ``randomized``: the interleaved split on worlds collected with ``--randomize`` (other
  materials and lighting per seed).

Usage::

    topomap collect --world all --seed S --out ROOT/m-data-S            (S = 0 .. 10)
    topomap collect --world all --seed S --randomize --out ROOT/m-data-rS
    python -m scripts.manifold_protocol --root ROOT --out out/protocol --seeds 1 2 3 \
        --randomized 1 2 --features hsv raw

Results are cached per (condition, features, seed) in ``OUT/cells/*.json``, so a later call
with more seeds only computes the new cells; ``--table`` prints the summary table.
"""

from __future__ import annotations

import argparse
import json
from pathlib import Path

import numpy as np

from common.fileio import atomic_write_bytes
from mapping import ColorHistogramFeatures, ImageFeatures
from scripts.manifold_methods import METHODS, bootstrap_mean, score_methods

K, Q = 8, 35  # the paper's Section III-B
DEV_SEED = 0
CONDITIONS = ("interleaved", "held-out", "randomized")
FEATURES = {
    "hsv": ("HSV histograms 8x4x4, 2x2 cells", ColorHistogramFeatures),
    "raw": ("raw pixels 320x240 RGB (paper)", ImageFeatures),
}


def dataset_dir(root: Path, seed: int, randomized: bool = False) -> Path:
    """Where ``topomap collect`` was asked to put the dataset of ``seed``."""
    return Path(root) / f"m-data-{'r' if randomized else ''}{seed}"


def _load(path: Path):
    from sim.dataset import load_dataset

    data = load_dataset(path)
    if not data.has_ground_truth:
        raise ValueError(f"{path}: the protocol needs a simulated dataset with labels")
    return data


def cell(root: Path, condition: str, features: str, seed: int) -> dict:
    """Errors of every method in one (condition, features, seed) cell of the protocol."""
    if condition not in CONDITIONS:
        raise ValueError(f"condition must be one of {CONDITIONS}, got {condition!r}")
    if features not in FEATURES:
        raise ValueError(f"features must be one of {tuple(FEATURES)}, got {features!r}")
    train_data = _load(dataset_dir(root, seed, condition == "randomized"))
    test_data = _load(dataset_dir(root, seed + 1)) if condition == "held-out" else train_data
    train, _ = train_data.paper_split()
    _, test = test_data.paper_split()
    images_train = train_data.concat("images")[train]
    images_test = test_data.concat("images")[test]
    transformer = FEATURES[features][1]().fit(images_train)
    X_train = transformer.transform(images_train)
    X_test = transformer.transform(images_test)
    del images_train, images_test
    y_train = train_data.concat("labels")[train]
    y_test = test_data.concat("labels")[test]
    rows = score_methods(X_train, y_train, K, Q, X_test, y_test)
    return {
        "condition": condition,
        "features": features,
        "seed": seed,
        "test_seed": seed + 1 if condition == "held-out" else seed,
        "n_train": len(y_train),
        "n_test": len(y_test),
        "rows": rows,
    }


def _cell_path(out: Path, condition: str, features: str, seed: int) -> Path:
    return out / "cells" / f"{condition}-{features}-{seed}.json"


def run_cells(root: Path, out: Path, plan: list[tuple[str, str, int]], progress=True) -> None:
    """Compute the cells of ``plan`` not cached yet; a dataset not collected (or not completely)
    is skipped with a message."""
    from tqdm.auto import tqdm

    from sim.dataset import DatasetError

    (out / "cells").mkdir(parents=True, exist_ok=True)
    for condition, features, seed in tqdm(plan, disable=not progress, desc="protocol cells"):
        path = _cell_path(out, condition, features, seed)
        if path.exists():
            continue
        needed = [dataset_dir(root, seed, condition == "randomized")]
        if condition == "held-out":
            needed.append(dataset_dir(root, seed + 1))
        if not all((p / "meta.json").exists() for p in needed):
            print(f"skipped {condition}/{features}/seed {seed}: dataset not collected yet")
            continue
        try:
            result = cell(root, condition, features, seed)
        except DatasetError as err:  # e.g. a collection that stopped half-way
            print(f"skipped {condition}/{features}/seed {seed}: {err}")
            continue
        atomic_write_bytes(path, (json.dumps(result, indent=2) + "\n").encode())


def load_cells(out: Path) -> list[dict]:
    """Every cached cell under ``out/cells``, checked for the fields the summary reads."""
    cells = []
    for path in sorted((Path(out) / "cells").glob("*.json")):
        data = json.loads(path.read_text())
        if not (isinstance(data, dict) and {"condition", "features", "seed", "rows"} <= set(data)):
            raise ValueError(f"{path}: not a protocol cell (condition, features, seed, rows)")
        cells.append(data)
    return cells


def summarize(cells: list[dict], seed: int = 0) -> list[dict]:
    """Per (condition, features, method): test errors over the fresh seeds (dev seed left
    out) as mean and bootstrap 95% interval, the dev seed's error beside them."""
    rng = np.random.default_rng(seed)
    groups: dict[tuple, dict] = {}
    for c in cells:
        for r in c["rows"]:
            key = (c["condition"], c["features"], r["method"])
            g = groups.setdefault(key, {"dev": None, "fresh": {}})
            if c["seed"] == DEV_SEED:
                g["dev"] = r["test_error"]
            else:
                g["fresh"][c["seed"]] = r["test_error"]
    rows = []
    for (condition, features, method), g in sorted(
        groups.items(), key=lambda kv: (CONDITIONS.index(kv[0][0]), kv[0][1], _order(kv[0][2]))
    ):
        seeds = sorted(g["fresh"])
        errors = [g["fresh"][s] for s in seeds]
        stats = bootstrap_mean(errors, rng) if errors else None
        rows.append(
            {
                "condition": condition,
                "features": features,
                "method": method,
                "dev_error": g["dev"],
                "seeds": seeds,
                "errors": errors,
                "summary": stats,
            }
        )
    return rows


def _order(method: str) -> int:
    return METHODS.index(method) if method in METHODS else len(METHODS)


def markdown(summary: list[dict]) -> str:
    """The summary as a markdown table (errors in %)."""
    lines = [
        "| condition | features | method | dev seed 0 | fresh seeds: mean [95% CI] | n | min-max |",
        "|---|---|---|---|---|---|---|",
    ]
    for r in summary:
        dev = "--" if r["dev_error"] is None else f"{r['dev_error']:.1%}"
        s = r["summary"]
        if s is None:
            fresh, spread = "--", "--"
        else:
            fresh = f"{s['mean']:.1%} [{s['lo']:.1%}, {s['hi']:.1%}]"
            spread = f"{min(r['errors']):.1%}-{max(r['errors']):.1%}"
        n = 0 if s is None else s["n"]
        lines.append(
            f"| {r['condition']} | {r['features']} | {r['method']} | {dev} | {fresh} | {n} "
            f"| {spread} |"
        )
    return "\n".join(lines)


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--root", type=Path, required=True, help="folder of the m-data-* sets")
    parser.add_argument("--out", type=Path, required=True, help="folder for cells/ and table")
    parser.add_argument("--seeds", type=int, nargs="*", default=[], help="fresh seeds")
    parser.add_argument("--randomized", type=int, nargs="*", default=[], help="randomised seeds")
    parser.add_argument("--features", nargs="+", choices=tuple(FEATURES), default=["hsv"])
    parser.add_argument(
        "--conditions", nargs="+", choices=CONDITIONS, default=["interleaved", "held-out"]
    )
    parser.add_argument("--table", action="store_true", help="print the summary table")
    args = parser.parse_args(argv)
    plan = []
    for seed in [DEV_SEED, *args.seeds]:
        for features in args.features:
            for condition in args.conditions:
                if condition != "randomized":
                    plan.append((condition, features, seed))
    if "randomized" in args.conditions:
        for seed in [DEV_SEED, *args.randomized]:
            plan += [("randomized", f, seed) for f in args.features]
    run_cells(args.root, args.out, plan)
    summary = summarize(load_cells(args.out))
    atomic_write_bytes(args.out / "summary.json", (json.dumps(summary, indent=2) + "\n").encode())
    if args.table:
        print(markdown(summary))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
