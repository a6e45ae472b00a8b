"""Reading the committed result files.

One estimate with its interval per row of the results table, and where each file came from.

Every reader takes a file (or folder) under ``docs/results/data/`` and a few keys saying which
number in it a row shows, and returns an `Estimate`. Rates come with their Wilson 95%
interval (``servo.task.stats``), errors and scores averaged over seeds with a bootstrap 95%
interval (``scripts.manifold.bootstrap_mean``, the protocol's own summary).
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from common.fileio import read_json

__all__ = ["READERS", "Estimate", "provenance", "read_estimate", "servo_results"]

BOOTSTRAP_SEED = 0  # the protocol summary's own generator seed (scripts.manifold.summarize)


@dataclass(frozen=True)
class Estimate:
    """One number of the results table.

    Parameters
    ----------
    value : float
        The estimate.
    interval : tuple of (float, float) or None
        Its 95% interval (None where there is none: a single real log without ground truth).
    n : int
        How many independent units it rests on.
    unit : str
        What they are (episodes, seeds, logs).
    """

    value: float
    interval: tuple[float, float] | None
    n: int
    unit: str


def servo_results(path: Path) -> list[dict]:
    """Read the entries of a ``topomap servo-eval --out`` file (one per world).

    Parameters
    ----------
    path : Path
        The file.

    Returns
    -------
    list of dict
        The entries.

    Raises
    ------
    ValueError
        If the file holds no list of entries.
    """
    from scripts.leaderboard import servo_results_of

    data = servo_results_of(read_json(path))
    if not isinstance(data, list) or not all(isinstance(e, dict) for e in data):
        raise ValueError(f"{path}: a servo-eval result (a list of one entry per world) expected")
    return data


def _servo_success(path: Path, world: str) -> Estimate:
    """Rate the successes over episodes of ``world`` in a servo-eval file, Wilson 95%."""
    from servo.task import wilson_interval

    entries = [e for e in servo_results(path) if e.get("world") == world]
    if len(entries) != 1:
        raise ValueError(f"{path}: one entry for world {world!r} expected, found {len(entries)}")
    e = entries[0]
    successes, n = int(e["successes"]), int(e["episodes"])
    return Estimate(successes / n, wilson_interval(successes, n), n, "episodes")


def _mean_over_seeds(values: list[float], unit: str = "seeds") -> Estimate:
    from scripts.manifold import bootstrap_mean

    s = bootstrap_mean(values, np.random.default_rng(BOOTSTRAP_SEED))
    interval = (s["lo"], s["hi"]) if s["n"] > 1 else None  # one seed gives no spread
    return Estimate(s["mean"], interval, s["n"], unit)


def _protocol_error(folder: Path, condition: str, features: str, method: str) -> Estimate:
    """Average the test error of ``method`` over the protocol's fresh seeds, bootstrap 95%.

    The dev seed is left out, as in ``scripts.manifold.summarize``.
    """
    from scripts.manifold import load_cells, summarize

    for row in summarize(load_cells(folder), seed=BOOTSTRAP_SEED):
        key = (row["condition"], row["features"], row["method"])
        if key == (condition, features, method) and row["summary"] is not None:
            s = row["summary"]
            return Estimate(s["mean"], (s["lo"], s["hi"]), s["n"], "seeds")
    raise ValueError(f"{folder}: no fresh-seed cells of {condition}/{features}/{method}")


def _grouping_score(folder: Path, pattern: str, world: str, variant: str, score: str) -> Estimate:
    """Average ``score`` (purity, ARI) of the scan grouping of ``world`` over dataset seeds.

    The scan grouping is the one with ``variant`` poses; the mean is over the group-eval files
    matching ``pattern`` (one per dataset seed), bootstrap 95%.
    """
    files = sorted(folder.glob(pattern))
    if not files:
        raise ValueError(f"{folder}: no file matches {pattern!r}")
    values = [float(read_json(f)["default"][world][variant][score]) for f in files]
    return _mean_over_seeds(values)


def _carmen_groups(path: Path, log: str, variant: str) -> Estimate:
    """Count the groups of a real log (no ground truth: the count itself, no interval)."""
    entry = read_json(path)["logs"][log]
    return Estimate(float(entry[variant]["groups"]), None, 1, f"log ({entry['scans']} scans)")


READERS: dict[str, Callable[..., Estimate]] = {
    "servo-success": _servo_success,
    "protocol-error": _protocol_error,
    "grouping-score": _grouping_score,
    "carmen-groups": _carmen_groups,
}


def read_estimate(data_dir: Path, reader: str, source: str, **keys) -> Estimate:
    """Read the estimate ``reader`` takes from ``data_dir / source`` with ``keys``.

    Parameters
    ----------
    data_dir : Path
        The folder of the result files.
    reader : str
        One of `READERS`.
    source : str
        The file or folder under ``data_dir`` (for ``grouping-score``, a file pattern).
    **keys
        Which number in it the row shows, passed to the reader.

    Returns
    -------
    Estimate
        The estimate.
    """
    if reader not in READERS:
        raise ValueError(f"reader must be one of {sorted(READERS)}, got {reader!r}")
    path = data_dir / source
    if reader == "grouping-score":  # a file pattern under a folder, one file per seed
        return READERS[reader](path.parent, path.name, **keys)
    if not path.exists():
        raise FileNotFoundError(f"{path}: result file missing")
    return READERS[reader](path, **keys)


def provenance(data_dir: Path, source: str) -> dict:
    """Read how ``source`` was made: command, commit, machine, date (and notes).

    They come from the ``meta.json`` beside it (a folder's own ``meta.json``, else its folder's
    entry for it).

    Parameters
    ----------
    data_dir : Path
        The folder of the result files.
    source : str
        The file or folder under ``data_dir``.

    Returns
    -------
    dict
        The entries.
    """
    path = data_dir / source
    if path.is_dir():
        return dict(read_json(path / "meta.json"))
    meta = read_json(path.parent / "meta.json")
    if path.name not in meta:
        raise ValueError(f"{path.parent / 'meta.json'}: no entry for {path.name}")
    return dict(meta[path.name])
