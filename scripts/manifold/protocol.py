"""A frozen evaluation protocol for manifold clustering on the image datasets.

Every choice (features: HSV histograms 8x4x4 in 2x2 cells; the combination of the leaves,
``spectral``, which replaced ``separability``; K = 8, Q = 35; the baselines'
label-free rules) was made on the ``dev`` dataset, seed 0, the one
``docs/guides/manifold-clustering.md`` was written on. This script applies them unchanged to fresh
dataset seeds and reports every method's error per seed and as a mean with a bootstrap 95%
interval over seeds. Conditions (``CONDITIONS``):

* ``interleaved``: even frames of each sequence build the map, odd frames test it (the paper's
  split; test frames lie ~0.1 m from training frames);
* ``held-out``: the map from seed S's even frames, the test frames are the odd frames of seed
  S+1's drives (another traversal of the same worlds, other teleop jitter);
* ``randomized``: the interleaved split on worlds collected with ``--randomize`` (other
  materials and lighting per seed);
* ``hard``: the interleaved split on worlds collected with ``--appearance hard`` (every branch
  in the main manifold's materials, so colour cannot tell the branches apart; same drives as
  the default dataset of the same seed).

Usage::

    topomap collect --world all --seed S --out ROOT/m-data-S            (S = 0 .. 10)
    topomap collect --world all --seed S --randomize --out ROOT/m-data-rS
    topomap collect --world all --seed S --appearance hard --out ROOT/m-data-hS
    python -m scripts.manifold.protocol --root ROOT --out out/protocol --seeds 1 2 3 \
        --randomized 1 2 --hard 1 2 --features hsv raw \
        --conditions interleaved held-out randomized hard

Features (``--features``): ``hsv`` and ``raw`` from the camera images; ``scan-range``,
``scan-inverse``, ``scan-polar`` (``mapping.ScanFeatures``) and ``scan-stats``
(``mapping.ScanStatistics``: sector and ring statistics) from the laser scans of the same
frames. ``--methods`` computes a subset of the methods; a later call with
more methods adds them to the cached cells.

Each dataset's ``meta.json`` must say it was collected for its condition (randomised or not,
its appearance mode), so that a dataset in the wrong folder is refused, not scored.

Results are cached per (condition, features, seed) in ``OUT/cells/*.json``, so a later call
with more seeds only computes the new cells; ``--table`` prints the summary table.
"""

from __future__ import annotations

import argparse
import json
import warnings
from pathlib import Path

import numpy as np

from common.fileio import UnreadableJSON, atomic_write_bytes, read_json
from mapping import ColorHistogramFeatures, ImageFeatures, ScanFeatures, ScanStatistics
from scripts.manifold.methods import METHODS, bootstrap_mean, score_methods

K, Q = 8, 35  # the paper's Section III-B
# name and version of this protocol in result files (scripts.leaderboard); the version goes up
# whenever a change alters the numbers a method gets (datasets, splits, features, K, scoring)
PROTOCOL = ("manifold-clustering-datasets", 1)
DEV_SEED = 0
CONDITIONS = ("interleaved", "held-out", "randomized", "hard")
# condition -> (folder prefix, the collection settings its datasets must have been made with)
_DATASETS = {
    "interleaved": ("", {"randomize": False, "appearance": "default"}),
    "held-out": ("", {"randomize": False, "appearance": "default"}),
    "randomized": ("r", {"randomize": True, "appearance": "default"}),
    "hard": ("h", {"randomize": False, "appearance": "hard"}),
}
FEATURES = {
    "hsv": ("HSV histograms 8x4x4, 2x2 cells", ColorHistogramFeatures),
    "raw": ("raw pixels 320x240 RGB (paper)", ImageFeatures),
}
# laser scans: name -> (description, the transformer for a sensor's max range)
SCAN_FEATURES = {
    "scan-range": ("laser ranges / max range, 361 beams", lambda m: ScanFeatures(m, "range")),
    "scan-inverse": ("inverse laser ranges", lambda m: ScanFeatures(m, "inverse")),
    "scan-polar": ("polar grid, 16 sectors x 8 ranges", lambda m: ScanFeatures(m, "polar_grid")),
    "scan-stats": ("sector and ring statistics (mapping.ScanStatistics)", ScanStatistics),
}
ALL_FEATURES = (*FEATURES, *SCAN_FEATURES)


def _check_condition(condition: str) -> str:
    if condition not in CONDITIONS:
        raise ValueError(f"condition must be one of {CONDITIONS}, got {condition!r}")
    return condition


def dataset_dir(root: Path, seed: int, condition: str = "interleaved") -> Path:
    """Return where ``topomap collect`` was asked to put the dataset of ``seed`` for ``condition``.

    Parameters
    ----------
    root : Path
        The folder of the ``m-data-*`` datasets.
    seed : int
        The dataset seed.
    condition : str, default "interleaved"
        One of ``CONDITIONS``.

    Returns
    -------
    Path
        ``root/m-data-<prefix><seed>``.
    """
    return Path(root) / f"m-data-{_DATASETS[_check_condition(condition)][0]}{seed}"


def load_for(path: Path, condition: str):
    """Load the labelled dataset at ``path`` for ``condition``.

    It is refused unless its ``meta.json`` says it was collected for ``condition``
    (randomised or not, its appearance mode).

    Parameters
    ----------
    path : Path
        The dataset.
    condition : str
        One of ``CONDITIONS``.

    Returns
    -------
    Dataset
        The dataset (``sim.dataset``).

    Raises
    ------
    ValueError
        When it has no labels or was collected for another condition.
    """
    from sim.dataset import load_dataset

    _check_condition(condition)
    data = load_dataset(path)
    if not data.has_ground_truth:
        raise ValueError(f"{path}: the protocol needs a simulated dataset with labels")
    settings = data.meta.get("settings", {})
    # a dataset without the key predates the option: default appearance, as ``to_json`` says
    made = {
        "randomize": settings.get("randomize"),
        "appearance": settings.get("appearance", "default"),
    }
    if made != _DATASETS[condition][1]:
        raise ValueError(
            f"{path}: condition {condition!r} needs a dataset collected with "
            f"{_DATASETS[condition][1]}, this one was collected with {made}"
        )
    return data


def cell_data(root: Path, condition: str, features: str, seed: int):
    """Load the features and labels of one (condition, features, seed) cell.

    The features are fitted on the training frames.

    Parameters
    ----------
    root : Path
        The folder of the ``m-data-*`` datasets.
    condition : str
        One of ``CONDITIONS``.
    features : str
        One of ``ALL_FEATURES``.
    seed : int
        The dataset seed (the test frames of ``held-out`` are seed + 1's).

    Returns
    -------
    X_train : ndarray of shape (n, d)
        Training features.
    y_train : ndarray of shape (n,)
        Training labels.
    X_test : ndarray of shape (m, d)
        Test features.
    y_test : ndarray of shape (m,)
        Test labels.
    """
    _check_condition(condition)
    if features not in ALL_FEATURES:
        raise ValueError(f"features must be one of {ALL_FEATURES}, got {features!r}")
    train_data = load_for(dataset_dir(root, seed, condition), condition)
    test_data = train_data
    if condition == "held-out":
        test_data = load_for(dataset_dir(root, seed + 1, condition), condition)
    train, _ = train_data.paper_split()
    _, test = test_data.paper_split()
    if features in SCAN_FEATURES:
        # the training dataset's sensor limit; both drives use the same laser
        transformer = SCAN_FEATURES[features][1](train_data.max_range)
        sensor = "scans"
    else:
        transformer = FEATURES[features][1]()
        sensor = "images"
    readings_train = train_data.concat(sensor)[train]
    readings_test = test_data.concat(sensor)[test]
    transformer.fit(readings_train)
    X_train = transformer.transform(readings_train)
    X_test = transformer.transform(readings_test)
    del readings_train, readings_test
    y_train = train_data.concat("labels")[train]
    y_test = test_data.concat("labels")[test]
    return X_train, y_train, X_test, y_test


def cell(
    root: Path, condition: str, features: str, seed: int, methods: tuple[str, ...] = METHODS
) -> dict:
    """Score ``methods`` in one (condition, features, seed) cell of the protocol.

    Parameters
    ----------
    root : Path
        The folder of the ``m-data-*`` datasets.
    condition : str
        One of ``CONDITIONS``.
    features : str
        One of ``ALL_FEATURES``.
    seed : int
        The dataset seed.
    methods : tuple of str, default METHODS
        The methods to score (default: every method).

    Returns
    -------
    dict
        The cell: its condition, features, seeds, training and test sizes, and the rows of
        ``score_methods``.
    """
    X_train, y_train, X_test, y_test = cell_data(root, condition, features, seed)
    rows = score_methods(X_train, y_train, K, Q, X_test, y_test, methods=tuple(methods))
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


def run_cells(
    root: Path,
    out: Path,
    plan: list[tuple[str, str, int]],
    progress=True,
    methods: tuple[str, ...] = METHODS,
) -> None:
    """Compute the cells of ``plan`` not cached yet, for ``methods``.

    A cached cell that lacks some of them gets only those added. A dataset not collected (or
    not completely) is skipped with a message.

    Parameters
    ----------
    root : Path
        The folder of the ``m-data-*`` datasets.
    out : Path
        The output folder; cells are cached in ``out/cells``.
    plan : list of tuple of (str, str, int)
        The (condition, features, seed) cells.
    progress : bool, default True
        Whether to show a progress bar.
    methods : tuple of str, default METHODS
        The methods each cell needs.
    """
    from tqdm.auto import tqdm

    from sim.dataset import DatasetError

    (out / "cells").mkdir(parents=True, exist_ok=True)
    for condition, features, seed in tqdm(plan, disable=not progress, desc="protocol cells"):
        path = _cell_path(out, condition, features, seed)
        cached = _cached_cell(path)
        done = {r["method"] for r in cached["rows"]} if cached else set()
        missing = tuple(m for m in methods if m not in done)
        if not missing:
            continue
        needed = [dataset_dir(root, seed, condition)]
        if condition == "held-out":
            needed.append(dataset_dir(root, seed + 1, condition))
        if not all((p / "meta.json").exists() for p in needed):
            print(f"skipped {condition}/{features}/seed {seed}: dataset not collected yet")
            continue
        try:
            result = cell(root, condition, features, seed, missing)
        except DatasetError as err:  # e.g. a collection that stopped half-way
            print(f"skipped {condition}/{features}/seed {seed}: {err}")
            continue
        if cached:  # keep the methods computed before, in the tables' order
            rows = cached["rows"] + result["rows"]
            result["rows"] = sorted(rows, key=lambda r: _order(r["method"]))
        atomic_write_bytes(path, (json.dumps(result, indent=2) + "\n").encode())


def _cached_cell(path: Path) -> dict | None:
    """Read the cell cached at ``path``.

    None where there is none, and where the file is not a cell (unreadable, damaged or
    foreign: `_cell_problem`), which is then computed again with a warning, as any cache
    would be.
    """
    if not path.exists():
        return None
    try:
        data = read_json(path)
    except UnreadableJSON as err:
        problem = f"not JSON ({err})"
    else:
        problem = _cell_problem(data)
    if problem:
        warnings.warn(
            f"{path}: computed again, the cached cell is unusable: {problem}",
            RuntimeWarning,
            stacklevel=3,
        )
        return None
    return data


def load_cells(out: Path) -> list[dict]:
    """Read every cached cell under ``out/cells``, checked for the fields the summary reads.

    The files may come from elsewhere: the report reads a folder it is given.

    Parameters
    ----------
    out : Path
        The output folder.

    Returns
    -------
    list of dict
        The cells, in file name order.

    Raises
    ------
    ValueError
        When a file there is not a protocol cell.
    """
    cells = []
    for path in sorted((Path(out) / "cells").glob("*.json")):
        try:
            data = read_json(path)
        except UnreadableJSON as err:
            raise ValueError(f"{path}: not a protocol cell: not JSON ({err})") from err
        problem = _cell_problem(data)
        if problem:
            raise ValueError(
                f"{path}: not a protocol cell (condition, features, seed, rows): {problem}"
            )
        cells.append(data)
    return cells


def _cell_problem(data) -> str | None:
    """Say what is wrong with a cell read from disk, or return None."""
    if not (isinstance(data, dict) and {"condition", "features", "seed", "rows"} <= set(data)):
        return "a JSON object with these keys expected"
    if data["condition"] not in CONDITIONS:
        return f"condition must be one of {CONDITIONS}, got {data['condition']!r}"
    if not isinstance(data["features"], str):
        return f"features must be a string, got {data['features']!r}"
    if not isinstance(data["seed"], int) or isinstance(data["seed"], bool) or data["seed"] < 0:
        return f"seed must be an integer >= 0, got {data['seed']!r}"
    if not isinstance(data["rows"], list):
        return "rows must be a list"
    for row in data["rows"]:
        ok = isinstance(row, dict) and isinstance(row.get("method"), str)
        error = row.get("test_error") if ok else None
        is_number = isinstance(error, int | float) and not isinstance(error, bool)
        if not (ok and is_number and 0.0 <= error <= 1.0):
            return f"each row must have a method name and a test_error in [0, 1], got {row!r}"
    return None


def summarize(cells: list[dict], seed: int = 0) -> list[dict]:
    """Summarise the test errors per (condition, features, method).

    The errors over the fresh seeds (dev seed left out) as mean and bootstrap 95% interval,
    the dev seed's error beside them.

    Parameters
    ----------
    cells : list of dict
        The cells (``load_cells``).
    seed : int, default 0
        Seed of the bootstrap.

    Returns
    -------
    list of dict
        One row per (condition, features, method): ``dev_error``, ``seeds``, ``errors``
        and ``summary`` (``bootstrap_mean``, None without fresh seeds).
    """
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
    """Format the summary as a markdown table (errors in %).

    Parameters
    ----------
    summary : list of dict
        The rows of ``summarize``.

    Returns
    -------
    str
        The table.
    """
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
    """Run ``python -m scripts.manifold.protocol``.

    Parameters
    ----------
    argv : list of str, optional
        The arguments; ``sys.argv[1:]`` by default.

    Returns
    -------
    int
        The exit status, 0.
    """
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--root", type=Path, required=True, help="folder of the m-data-* sets")
    parser.add_argument("--out", type=Path, required=True, help="folder for cells/ and table")
    parser.add_argument("--seeds", type=int, nargs="*", default=[], help="fresh seeds")
    parser.add_argument("--randomized", type=int, nargs="*", default=[], help="randomised seeds")
    parser.add_argument("--hard", type=int, nargs="*", default=[], help="hard-appearance seeds")
    parser.add_argument("--features", nargs="+", choices=ALL_FEATURES, default=["hsv"])
    parser.add_argument(
        "--conditions", nargs="+", choices=CONDITIONS, default=["interleaved", "held-out"]
    )
    parser.add_argument(
        "--methods", nargs="+", choices=METHODS, default=list(METHODS), help="default: all"
    )
    parser.add_argument("--table", action="store_true", help="print the summary table")
    args = parser.parse_args(argv)
    plan = []
    own_seeds = {"randomized": args.randomized, "hard": args.hard}
    for seed in [DEV_SEED, *args.seeds]:
        for features in args.features:
            for condition in args.conditions:
                if condition not in own_seeds:
                    plan.append((condition, features, seed))
    for condition, seeds in own_seeds.items():
        if condition in args.conditions:
            for seed in [DEV_SEED, *seeds]:
                plan += [(condition, f, seed) for f in args.features]
    run_cells(args.root, args.out, plan, methods=tuple(args.methods))
    summary = summarize(load_cells(args.out))
    atomic_write_bytes(args.out / "summary.json", (json.dumps(summary, indent=2) + "\n").encode())
    if args.table:
        print(markdown(summary))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
