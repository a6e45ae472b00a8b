"""What the laser scans can tell about the manifolds: a supervised bound,
then the label-free methods on the same features.

    python -m experiments.manifold.laser_bound --dev ROOT/m-data-0 --test ROOT/m-data-1 ... --out
    OUT

The bound: a classifier trained with the labels of the ``dev`` dataset (every frame of its
drives) predicts the manifold of every frame of each ``test`` dataset, whose drives are other
traversals of the same worlds (another seed's teleop). Its error is what a scan feature can at
best support; a label-free method on the same feature cannot be expected to do better. Two
classifiers a user would pick: 5-nearest-neighbours (the neighbourhood view the clustering
methods share) and a random forest (no neighbourhood assumption).

Then, per test dataset on the paper's split (even frames), the clustering error of
``ManifoldClustering`` (K = 8, Q = 35) and of scikit-learn's kNN spectral clustering (k = 10),
with the frames' true manifolds; per-seed values and the mean with a bootstrap 95 % interval.

Representations: ``range`` (ranges over the sensor's maximum), ``inverse`` (inverse range: near
structure weighs most) and ``polar_grid`` (returns counted in sectors x range rings), all
``mapping.ScanFeatures``; ``sector_rings`` (``mapping.ScanStatistics``: per 15-degree sector the
mean, min and std of the range, the no-return fraction and the mean inverse range, plus a
rotation-invariant ring histogram, each block scaled to unit spread on the training scans).
``--bound-only`` skips the label-free fits (``scripts.manifold.protocol`` measures those).
"""

from __future__ import annotations

import argparse
import os
from pathlib import Path

import numpy as np

from mapping import ManifoldClustering, ScanFeatures, ScanStatistics, clustering_error
from mapping.baselines.label_free import KNNSpectralClustering
from scripts.manifold.methods import seed_error_row, seed_error_table
from scripts.tables import Column

__all__ = ["JSON_FILE", "REPRESENTATIONS", "evaluate", "format_report", "main"]

JSON_FILE = "laser_bound.json"
REPRESENTATIONS = ("range", "inverse", "polar_grid", "sector_rings")
K, Q = 8, 35


def _scans(path):
    from sim.dataset import load_dataset

    data = load_dataset(path)
    if not data.has_ground_truth:
        raise ValueError(f"{data.path}: the laser bound needs the true manifold labels")
    return data.concat("scans"), data.concat("labels").astype(int), data.paper_split()[0], data


def scan_transformer(representation: str, max_range: float):
    """The unfitted scan transformer of a representation name (see the module docstring)."""
    if representation == "sector_rings":
        return ScanStatistics(max_range)
    if representation not in REPRESENTATIONS:
        raise ValueError(f"representation must be one of {REPRESENTATIONS}, got {representation!r}")
    return ScanFeatures(max_range=max_range, representation=representation)


def _classifiers(seed: int) -> dict:
    from sklearn.ensemble import RandomForestClassifier
    from sklearn.neighbors import KNeighborsClassifier

    return {
        "5-NN (supervised)": KNeighborsClassifier(5),
        "random forest (supervised)": RandomForestClassifier(200, random_state=seed, n_jobs=1),
    }


def evaluate(
    dev,
    tests,
    *,
    representations=REPRESENTATIONS,
    seed: int = 0,
    n_clusters: int = K,
    min_size: int = Q,
    clustering: bool = True,
) -> dict:
    """The bound and the label-free errors for each representation (see the module doc);
    ``n_clusters`` and ``min_size`` are ``ManifoldClustering``'s K and Q (the paper's);
    ``clustering=False`` gives the bound alone."""
    X_dev, y_dev, _, dev_data = _scans(dev)
    max_range = dev_data.max_range
    loaded = [_scans(t) for t in tests]
    rng = np.random.default_rng(seed)
    result = {"dev": str(dev), "tests": [str(t) for t in tests], "cpu_count": os.cpu_count()}
    result["rows"] = []
    for rep in representations:
        features = scan_transformer(rep, max_range).fit(X_dev)
        F_dev = features.transform(X_dev)
        per_method: dict[str, list[float]] = {}
        for name, clf in _classifiers(seed).items():
            clf.fit(F_dev, y_dev)
            per_method[name] = [
                float(np.mean(clf.predict(features.transform(X)) != y)) for X, y, _, _ in loaded
            ]
        for X, y, train, _ in loaded if clustering else ():
            # the transformer of the test drive's own map frames (its block scales, if any)
            F = scan_transformer(rep, max_range).fit_transform(X[train])
            for name, model in (
                ("ours (label-free)", ManifoldClustering(n_clusters, min_size)),
                (
                    "scikit-learn kNN k=10 (label-free)",
                    KNNSpectralClustering(n_clusters, n_neighbors=10),
                ),
            ):
                labels = model.fit(F).labels_
                per_method.setdefault(name, []).append(clustering_error(y[train], labels))
        for name, errors in per_method.items():
            result["rows"].append(seed_error_row(errors, rng, representation=rep, method=name))
    return result


def format_report(result: dict) -> str:
    group = Column("representation", "scan features")
    table = seed_error_table(result["rows"], group, "method", "per test seed")
    return table.to_markdown().rstrip("\n")


def main(argv: list[str] | None = None) -> int:
    from common.fileio import write_json

    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--dev", type=Path, required=True, help="dataset whose labels train the bound")
    p.add_argument("--test", type=Path, nargs="+", required=True, help="other seeds' datasets")
    p.add_argument("--out", type=Path, required=True, help="output folder (laser_bound.json)")
    p.add_argument("--representation", nargs="+", choices=REPRESENTATIONS, default=None)
    p.add_argument("--bound-only", action="store_true", help="skip the label-free fits")
    args = p.parse_args(argv)
    result = evaluate(
        args.dev,
        args.test,
        representations=args.representation or REPRESENTATIONS,
        clustering=not args.bound_only,
    )
    args.out.mkdir(parents=True, exist_ok=True)
    write_json(args.out / JSON_FILE, result)
    print(format_report(result))
    print(f"\nwrote {args.out / JSON_FILE}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
