"""How much colour tells about the manifolds, by appearance mode: a
supervised bound on the frozen protocol's features (HSV histograms 8x4x4 in 2x2 cells).

    python -m experiments.manifold.colour_bound --root ROOT --seeds 1 2 3 --out OUT [--figure PNG]

A classifier trained with the labels of the dev dataset (seed 0, every frame) predicts the
manifold of every frame of each fresh seed's dataset (other drives of the same worlds), once on
the default worlds (``ROOT/m-data-S``) and once on the hard ones (``ROOT/m-data-hS``, the same
drives with every branch in the main manifold's materials; ``scripts.manifold.protocol``'s
folders). Its error is what these features can at best support with labels: if the hard mode
raises it, the default mode's manifolds were told apart by colour. Classifiers as in
``experiments.manifold.laser_bound``: 5-nearest-neighbours and a random forest.
"""

from __future__ import annotations

import argparse
from pathlib import Path

import numpy as np

from mapping import ColorHistogramFeatures
from scripts.manifold.methods import seed_error_row, seed_error_table
from scripts.manifold.protocol import DEV_SEED, dataset_dir, load_for
from scripts.tables import Column

__all__ = ["JSON_FILE", "MODES", "draw_modes", "evaluate", "format_report", "main"]

JSON_FILE = "colour_bound.json"
MODES = {"default": "interleaved", "hard": "hard"}  # appearance mode -> protocol condition


def _features(path: Path, condition: str, grid) -> tuple[np.ndarray, np.ndarray]:
    data = load_for(path, condition)  # labelled, and collected in the expected mode
    X = ColorHistogramFeatures(grid=grid).fit_transform(data.concat("images"))
    return X, data.concat("labels").astype(int)


def _classifiers(seed: int) -> dict:
    from sklearn.ensemble import RandomForestClassifier
    from sklearn.neighbors import KNeighborsClassifier

    return {
        "5-NN (supervised)": KNeighborsClassifier(5),
        "random forest (supervised)": RandomForestClassifier(200, random_state=seed, n_jobs=1),
    }


def evaluate(root: Path, seeds, modes=tuple(MODES), seed: int = 0, grid=(2, 2)) -> dict:
    """Per appearance mode and classifier: the error on each fresh seed's frames of a
    classifier trained on the dev seed's, and their mean with a bootstrap 95% interval.
    ``grid``: the histograms' cells (the protocol's 2x2; 1x1 keeps colour and drops where in
    the image it is)."""
    bad = [m for m in modes if m not in MODES]
    if bad or not modes:
        raise ValueError(f"modes must be a non-empty subset of {tuple(MODES)}, got {modes}")
    if not seeds or DEV_SEED in seeds:
        raise ValueError(f"seeds must be fresh seeds (not the dev seed {DEV_SEED}), got {seeds}")
    rng = np.random.default_rng(seed)
    result = {"root": str(root), "seeds": list(seeds), "grid": list(grid), "rows": []}
    for mode in modes:
        condition = MODES[mode]
        X_dev, y_dev = _features(dataset_dir(root, DEV_SEED, condition), condition, grid)
        tests = [_features(dataset_dir(root, s, condition), condition, grid) for s in seeds]
        for name, clf in _classifiers(seed).items():
            clf.fit(X_dev, y_dev)
            errors = [float(np.mean(clf.predict(X) != y)) for X, y in tests]
            result["rows"].append(seed_error_row(errors, rng, appearance=mode, method=name))
    return result


def format_report(result: dict) -> str:
    group = Column("appearance", "appearance")
    table = seed_error_table(
        result["rows"], group, "classifier (trained on the dev seed)", "per fresh seed (%)"
    )
    return table.to_markdown().rstrip("\n")


def draw_modes(root: Path, path: Path, seed: int = DEV_SEED) -> Path:
    """A figure of the middle frame of every manifold (columns, in ``scenes.MANIFOLDS`` order)
    in the default (top row) and the hard worlds (bottom row) of one seed: the same poses."""
    import cv2

    from common.fileio import write_png
    from scenes import MANIFOLDS
    from scripts.report.drawing import manifold_samples

    rows = []
    for condition in MODES.values():
        data = load_for(dataset_dir(root, seed, condition), condition)
        tiles = []
        for m, (seq, frames) in manifold_samples(data).items():
            tile = cv2.resize(seq.images[frames[1]], (160, 120), interpolation=cv2.INTER_AREA)
            cv2.putText(
                tile,
                MANIFOLDS[m],
                (3, 12),
                cv2.FONT_HERSHEY_SIMPLEX,
                0.33,
                (255, 255, 255),
                1,
                cv2.LINE_AA,
            )
            tiles.append(tile)
        rows.append(np.concatenate(tiles, axis=1))
    return write_png(Path(path), np.concatenate(rows, axis=0))


def main(argv: list[str] | None = None) -> int:
    from common.fileio import write_json

    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--root", type=Path, required=True, help="folder of the m-data-* sets")
    p.add_argument("--seeds", type=int, nargs="+", required=True, help="fresh seeds")
    p.add_argument("--modes", nargs="+", choices=tuple(MODES), default=list(MODES))
    p.add_argument("--out", type=Path, required=True, help="output folder (colour_bound.json)")
    p.add_argument("--figure", type=Path, default=None, help="PNG: the dev seed, both modes")
    p.add_argument(
        "--grid",
        type=int,
        nargs=2,
        default=(2, 2),
        metavar=("COLUMNS", "ROWS"),
        help="histogram cells (default: the protocol's 2 2)",
    )
    args = p.parse_args(argv)
    if args.figure is not None:
        print(f"wrote {draw_modes(args.root, args.figure)}")
    result = evaluate(args.root, args.seeds, tuple(args.modes), grid=tuple(args.grid))
    args.out.mkdir(parents=True, exist_ok=True)
    write_json(args.out / JSON_FILE, result)
    print(format_report(result))
    print(f"\nwrote {args.out / JSON_FILE}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
