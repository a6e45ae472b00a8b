"""Paired comparison on fresh dataset seeds: ``ManifoldClustering`` against scikit-learn's
10-NN spectral clustering, fitted in the same run on the same frames.

For every seed and condition (interleaved; held-out: trained on seed S, tested on the drive
of seed S + 1) the cells of ``experiments.manifold.combination_acceptance`` (HSV features,
K = 8, Q = ``--Q``, test error Hungarian-matched) give both methods' errors. Per condition:
the per-seed errors, the mean difference ours minus scikit-learn with its 95 % percentile
bootstrap interval (4000 resamples of the seeds, ``numpy.random.default_rng(0)``), and the
number of seeds above 15 % error for each method. The rule is the one the dev studies chose
(``experiments/manifold/README.md``); no choice is made on these seeds.

Usage::

    python -m experiments.manifold.fresh_seeds --root ROOT --seeds $(seq 300 319) \
        --combine spectral --Q 20 --cache out/fresh \
        --out experiments/manifold/fresh_seeds.json
"""

from __future__ import annotations

import argparse
import json
from pathlib import Path

import numpy as np

from common.fileio import write_json
from experiments.manifold.combination_acceptance import CONDITIONS, MAX_ERROR, cell, verdict
from scripts.manifold.methods import SKLEARN_DEFAULT


def compare(cells: dict[int, dict], rule: str) -> dict:
    """The paired numbers of ``rule`` against scikit-learn over the seeds of ``cells``."""
    seeds = sorted(cells)
    theirs = np.array([cells[s][SKLEARN_DEFAULT]["test_error"] for s in seeds])
    out = verdict(cells, rule)
    return {
        "seeds": seeds,
        "ours": [round(float(cells[s][rule]["test_error"]), 4) for s in seeds],
        "scikit-learn": [round(float(e), 4) for e in theirs],
        "ours mean": out["ours mean"],
        "scikit-learn mean": out["scikit-learn mean"],
        "difference ours - scikit-learn": out["difference"],
        "ours seeds above 0.15": out["seeds above 0.15"],
        "scikit-learn seeds above 0.15": int((theirs > MAX_ERROR).sum()),
        "passes the acceptance criterion": out["passes"],
        "ours train error mean": float(np.mean([cells[s][rule]["train_error"] for s in seeds])),
    }


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--root", type=Path, required=True, help="folder of m-data-S datasets")
    parser.add_argument("--seeds", type=int, nargs="+", required=True)
    parser.add_argument("--combine", default="spectral", help="ManifoldClustering's combine")
    parser.add_argument("--Q", type=int, default=20, help="min_cluster_size")
    parser.add_argument("--conditions", nargs="+", default=list(CONDITIONS), choices=CONDITIONS)
    parser.add_argument("--cache", type=Path, required=True, help="folder of cached cells")
    parser.add_argument("--out", type=Path, help="JSON result file")
    args = parser.parse_args(argv)
    cache = args.cache / f"Q{args.Q}"
    cache.mkdir(parents=True, exist_ok=True)
    result = {"rule": args.combine, "K": 8, "Q": args.Q, "features": "hsv", "conditions": {}}
    for condition in args.conditions:
        cells = {}
        for seed in args.seeds:
            cells[seed] = cell(args.root, cache, condition, seed, [args.combine], args.Q)
            ours = cells[seed][args.combine]["test_error"]
            theirs = cells[seed][SKLEARN_DEFAULT]["test_error"]
            print(f"{condition} {seed}: ours {ours:.3f}, scikit-learn {theirs:.3f}", flush=True)
        result["conditions"][condition] = compare(cells, args.combine)
        print(condition, json.dumps(result["conditions"][condition]), flush=True)
    if args.out:
        write_json(args.out, result, indent=1)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
