"""Stability plot of the leaf combinations on the dev seeds (HSV, interleaved, K = 8, Q = 20).

For each dev seed, the train error at the chosen setting and two steps each side:

* ``spectral``: the cut at the grid sigma of largest total Omega(2) and at the grid sigmas
  -2 .. +2 steps from it (gaps where a sigma is unusable or off the grid), recomputed from the
  cached fits of ``experiments.manifold.ensemble_combination``;
* the ensembles (``coassociation`` with the finer cuts, ``consensus``): the grid window of
  S - 4 sigmas shifted by -2 .. +2 steps (the ensemble study's five windows);
* local scaling (``experiments.manifold.local_scaling``): the 5th .. 9th neighbour's distance
  as ``sigma_i`` (the 7th -2 .. +2).

Writes ``docs/img/manifold_combination_stability.png`` and the numbers beside it (``.json``).

Usage::

    python -m experiments.manifold.plot_stability --root ROOT --cache out/ensemble \
        --ensemble experiments/manifold/ensemble_combination.json \
        --local experiments/manifold/local_scaling.json \
        --out docs/img/manifold_combination_stability.png
"""

from __future__ import annotations

import argparse
import json
from pathlib import Path

import numpy as np

from common.fileio import write_json
from experiments.manifold.ensemble_combination import cuts, error, fitted, omega_total
from scripts.manifold.protocol import K

OFFSETS = (-2, -1, 0, 1, 2)
SERIES = {
    "spectral": "spectral (grid sigma)",
    "coassociation K..K+3": "coassociation (grid window)",
    "consensus": "consensus (grid window)",
    "local scaling, kernel": "local scaling, kernel (k-th neighbour)",
    "local scaling, affinity": "local scaling, affinity (k-th neighbour)",
}


def spectral_neighbourhood(fit: dict) -> list[float | None]:
    """Errors of the spectral cut at the chosen grid sigma -2 .. +2 steps (None: unusable)."""
    parts = cuts(fit, K)
    usable = [s for s in range(len(parts)) if parts[s] is not None]
    best = max(usable, key=lambda s: omega_total(fit, s, parts[s]))
    out = []
    for step in OFFSETS:
        s = best + step
        out.append(error(fit, parts[s]) if 0 <= s < len(parts) else None)
    return out


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--root", type=Path, required=True, help="folder of m-data-S datasets")
    parser.add_argument("--cache", type=Path, required=True, help="the ensemble study's fits")
    parser.add_argument("--ensemble", type=Path, required=True)
    parser.add_argument("--local", type=Path, required=True)
    parser.add_argument("--Q", type=int, default=20)
    parser.add_argument("--out", type=Path, required=True, help="PNG; the JSON goes beside")
    args = parser.parse_args(argv)
    ensemble = {r["seed"]: r for r in json.loads(args.ensemble.read_text())[f"Q={args.Q}"]["rows"]}
    local = {r["seed"]: r for r in json.loads(args.local.read_text())["rows"]}
    seeds = sorted(local)
    data = {}
    for seed in seeds:
        row = {"spectral": spectral_neighbourhood(fitted(args.root, args.cache, seed, args.Q))}
        for name in ("coassociation K..K+3", "consensus"):
            row[name] = ensemble[seed][name]["windows"]
        for name in ("local scaling, kernel", "local scaling, affinity"):
            row[name] = local[seed][name]["neighbours"]
        data[seed] = row

    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, axes = plt.subplots(2, (len(seeds) + 1) // 2, figsize=(15, 6), sharex=True, sharey=True)
    for ax, seed in zip(axes.ravel(), seeds, strict=False):
        for name, label in SERIES.items():
            y = [np.nan if e is None else 100 * e for e in data[seed][name]]
            ax.plot(OFFSETS, y, marker="o", ms=3, label=label)
        ax.axhline(15, color="grey", lw=0.5, ls="--")
        ax.set_title(f"dev seed {seed}", fontsize=9)
        ax.set_xticks(OFFSETS)
    for ax in axes[-1]:
        ax.set_xlabel("steps from the chosen setting")
    for ax in axes[:, 0]:
        ax.set_ylabel("train error (%)")
    axes.ravel()[0].legend(fontsize=7, loc="upper left")
    fig.suptitle(
        "Error around the chosen setting: spectral's grid sigma, the ensembles' grid window, "
        "local scaling's neighbour (HSV, interleaved, K = 8, Q = 20)",
        fontsize=10,
    )
    fig.tight_layout()
    args.out.parent.mkdir(parents=True, exist_ok=True)
    fig.savefig(args.out, dpi=90)
    numbers = {
        "offsets": list(OFFSETS),
        "what the offset moves": {
            "spectral": "grid sigma (16 log-spaced), from the one of largest total Omega(2)",
            "coassociation K..K+3": "window of 12 adjacent grid sigmas",
            "consensus": "window of 12 adjacent grid sigmas",
            "local scaling, kernel": "k of sigma_i = distance to the k-th neighbour, from 7",
            "local scaling, affinity": "k of sigma_i = distance to the k-th neighbour, from 7",
        },
        "train error per dev seed": {str(s): data[s] for s in seeds},
        "mean spread (largest - smallest) per rule": {
            name: float(
                np.mean([np.ptp([e for e in data[s][name] if e is not None]) for s in seeds])
            )
            for name in SERIES
        },
    }
    write_json(args.out.with_suffix(".json"), numbers, indent=1)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
