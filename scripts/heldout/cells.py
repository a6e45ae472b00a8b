"""One cell of the held-out evaluation: one world and one dataset seed, every mapping task.

A cell collects the world's dataset (one teleop drive per leaf manifold), then scores

* **manifold clustering** on the camera images (HSV histograms, the paper's interleaved split:
  even frames build the map, odd frames test it), ours (``ManifoldClustering``, Q = 35) beside
  scikit-learn's k-NN spectral clustering (k = 10), both told K = the world's manifold count;
* **observation grouping** of the laser scans (``ObservationGraphPartitioner`` with odometry
  and ICP, every drive in one graph): purity and groups per manifold;
* **servoing** (`scripts.heldout.servo_cell`): a servo map built from the same dataset,
  then the protocol's test episodes for both controllers and both start tiers.

A cell is a function of (world, seed, frames, servo episodes) alone and is cached as JSON, so
an evaluation resumes where it stopped and any backend gives the same numbers.
"""

from __future__ import annotations

import json
import time
from pathlib import Path

import numpy as np

from common.fileio import read_json, write_json
from scenes.families import check_world_name, parse_world_name

__all__ = ["MANIFOLD_Q", "OURS_SCALED", "TASKS", "cell_path", "run_cell", "scaled_q"]

TASKS = ("manifold", "grouping", "servo")
MANIFOLD_Q = 35  # the manifold protocol's Q, chosen on the canonical worlds' dev seed
OURS_SCALED = "ours, Q scaled"  # ManifoldClustering with Q from scaled_q
Q_DIVISOR, Q_MIN = 3, 8  # scaled_q's rule, chosen on dev worlds (experiments/heldout/q_rule.py)
CELL_VERSION = 1  # goes up whenever a change alters a cell's numbers
MANIFOLD_VERSION = 2  # the manifold task's own: a cell of another is scored again


def scaled_q(n: int, k: int) -> int:
    """Scale Q to the data: ``n // (3 k)`` within [8, 35].

    A generated world's drive crosses several stretches, so a short leaf gets
    fewer training frames than the protocol's Q = 35 (which the canonical worlds' leaves, at
    37-41, just exceed); with Q above a manifold's size no cluster can hold it.

    Parameters
    ----------
    n : int
        Training images.
    k : int
        Manifolds.

    Returns
    -------
    int
        Q.
    """
    return int(np.clip(n // (Q_DIVISOR * k), Q_MIN, MANIFOLD_Q))


def cell_path(out: Path, world: str, seed: int, frames: int) -> Path:
    """Return the cached JSON file of a cell: ``out/cells/<world>-s<seed>-f<frames>.json``.

    Parameters
    ----------
    out : Path
        The evaluation's output folder.
    world : str
        The world.
    seed : int
        The dataset seed.
    frames : int
        Frames per sequence.

    Returns
    -------
    Path
        The file.
    """
    stem = parse_world_name(world).file_stem
    return Path(out) / "cells" / f"{stem}-s{seed}-f{frames}.json"


def dataset_dir(data_root: Path, world: str, seed: int, frames: int) -> Path:
    """Return the dataset folder of a cell: ``data_root/<world>-s<seed>-f<frames>``.

    Parameters
    ----------
    data_root : Path
        The folder of the cells' datasets.
    world : str
        The world.
    seed : int
        The dataset seed.
    frames : int
        Frames per sequence.

    Returns
    -------
    Path
        The folder.
    """
    return Path(data_root) / f"{parse_world_name(world).file_stem}-s{seed}-f{frames}"


def _manifold(data, world) -> dict:
    from mapping import ColorHistogramFeatures
    from scripts.manifold import OURS, SKLEARN_DEFAULT, score_methods

    train, test = data.paper_split()
    images = data.concat("images")
    features = ColorHistogramFeatures().fit(images[train])
    X_train, X_test = features.transform(images[train]), features.transform(images[test])
    del images
    labels = data.concat("labels")
    k, n = len(world.manifold_names), int(train.sum())
    rows = []
    for name, method, q in (
        (OURS, OURS, MANIFOLD_Q),
        (OURS_SCALED, OURS, scaled_q(n, k)),
        (SKLEARN_DEFAULT, SKLEARN_DEFAULT, None),
    ):
        try:
            [row] = score_methods(
                X_train, labels[train], k, q or MANIFOLD_Q, X_test, labels[test], methods=(method,)
            )
        except ValueError as err:  # too few images for k clusters of q: the method refuses
            row = {"train_error": None, "test_error": None, "refused": str(err)}
        rows.append({**row, "method": name, "q": q})
    return {
        "version": MANIFOLD_VERSION,
        "k": k,
        "n_train": n,
        "n_test": int(test.sum()),
        "rows": rows,
    }


def _grouping(data, world) -> dict:
    from mapping.grouping import ObservationGraphPartitioner
    from scripts.grouping import score_groups

    runs = data.runs(world.name)
    model = ObservationGraphPartitioner(scan_matching=True)
    model.fit(runs.scans, runs.odometry, groups=runs.groups)
    score = score_groups(runs.labels, model.labels_, runs.manifold_names)
    keep = ("frames", "groups", "purity", "ari", "groups_per_manifold", "max_groups_per_manifold")
    return {k: score[k] for k in keep}


def run_cell(
    world: str,
    seed: int,
    out: Path,
    data_root: Path,
    frames: int = 150,
    tasks=TASKS,
    episodes: int = 3,
) -> dict:
    """Score ``tasks`` on ``world``'s dataset of ``seed``; cached in ``out/cells``.

    Parameters
    ----------
    world : str
        The world's name.
    seed : int
        The dataset seed.
    out : Path
        The evaluation's output folder.
    data_root : Path
        The folder of the cells' datasets.
    frames : int, default 150
        Frames per sequence.
    tasks : sequence of str, default TASKS
        A subset of `TASKS`.
    episodes : int, default 3
        Servo episodes per controller and start tier (a cached servo task run with another
        count is run again).

    Returns
    -------
    dict
        The cell: world, family, seed, frames, the world's manifolds and, per manifold, the
        junctions from the main one, then one entry per task.
    """
    from scenes import build_world
    from scripts.heldout.servo_cell import servo_task
    from sim.collect import CollectionSettings, collect_dataset
    from sim.dataset import load_dataset

    world = check_world_name(world)
    unknown = [t for t in tasks if t not in TASKS]
    if unknown:
        raise ValueError(f"tasks must be a subset of {TASKS}, got {list(tasks)}")
    path = cell_path(out, world, seed, frames)
    cell = _cached(path)
    done = dict(cell.get("tasks", {}))
    servo = done.get("servo", {})
    if servo.get("episodes") != episodes or "indices" not in servo:
        done.pop("servo", None)
    if done.get("manifold", {}).get("version") != MANIFOLD_VERSION:
        done.pop("manifold", None)
    todo = [t for t in tasks if t not in done]
    if not todo:
        return cell
    built = build_world(world)
    directory = dataset_dir(data_root, world, seed, frames)
    start = time.perf_counter()
    settings = CollectionSettings(worlds=(world,), frames=frames, seed=seed)
    collect_dataset(directory, settings, progress=False, jobs=1)
    collect_s = time.perf_counter() - start
    data = load_dataset(directory)
    main = built.manifold_names[0]
    cell.update(
        version=CELL_VERSION,
        world=world,
        family=parse_world_name(world).family,
        seed=seed,
        frames=frames,
        manifolds=list(built.manifold_names),
        junctions={m: built.junctions_between(main, m) for m in built.manifold_names},
        digest=built.digest,
    )
    cell.setdefault("tasks", {})
    cell.setdefault("seconds", {})["collect"] = collect_s
    for task in todo:
        start = time.perf_counter()
        if task == "manifold":
            cell["tasks"][task] = _manifold(data, built)
        elif task == "grouping":
            cell["tasks"][task] = _grouping(data, built)
        else:
            cell["tasks"][task] = servo_task(data, built, episodes)
        cell["seconds"][task] = time.perf_counter() - start
    path.parent.mkdir(parents=True, exist_ok=True)
    write_json(path, cell)
    return cell


def _cached(path: Path) -> dict:
    """Read a cached cell of the current version, or return an empty one.

    A stale or unreadable file is recomputed, not trusted.
    """
    if not path.is_file():
        return {}
    try:
        cell = read_json(path)
    except (OSError, ValueError, json.JSONDecodeError):
        return {}
    if not isinstance(cell, dict) or cell.get("version") != CELL_VERSION:
        return {}
    return cell


def manifold_errors(cells: list[dict], method: str) -> np.ndarray:
    """Return the test error of ``method`` per cell.

    Cells without the manifold task, and cells where the method refused the data, are left
    out: `manifold_refusals` counts those.

    Parameters
    ----------
    cells : list of dict
        Cells of `run_cell`.
    method : str
        The method's name in the manifold rows.

    Returns
    -------
    ndarray of float
        The test errors.
    """
    out = []
    for c in cells:
        rows = c.get("tasks", {}).get("manifold", {}).get("rows", [])
        out += [
            r["test_error"]
            for r in rows
            if r["method"] == method and r.get("test_error") is not None
        ]
    return np.asarray(out, float)


def manifold_refusals(cells: list[dict], method: str) -> int:
    """Count the cells where ``method`` refused the data (fewer images than K clusters of Q).

    Parameters
    ----------
    cells : list of dict
        Cells of `run_cell`.
    method : str
        The method's name in the manifold rows.

    Returns
    -------
    int
        The count.
    """
    return sum(
        r["method"] == method and r.get("test_error") is None
        for c in cells
        for r in c.get("tasks", {}).get("manifold", {}).get("rows", [])
    )
