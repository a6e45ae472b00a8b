"""The report's stages proper.

Each runs one part of the evaluation into its own folder of the report and returns a plain dict
for its section (paths relative to the report's root).
`scripts.report.pipeline` wraps them as named stages.
"""

from __future__ import annotations

from collections.abc import Sequence
from pathlib import Path

import numpy as np

from common.fileio import UnreadableJSON, read_json, write_png
from scripts.report.drawing import laser_crop, manifold_samples, sample_sheet
from scripts.report.provenance import REPO_ROOT
from scripts.report.settings import RunSettings

__all__ = [
    "stage_grouping",
    "stage_leaderboards",
    "stage_manifold",
    "stage_protocol",
    "stage_servo",
    "stage_worlds",
]


def _rel(path, root: Path) -> str:
    """Return ``path`` relative to the report root (paths may come absolute or relative to it)."""
    p = Path(path)
    return (p.resolve().relative_to(root.resolve()) if p.is_absolute() else p).as_posix()


def stage_worlds(dataset, out_dir: Path, root: Path) -> dict:
    """Draw top-down views with trajectories, and per manifold camera frames beside the laser.

    Parameters
    ----------
    dataset : Dataset
        The run's dataset.
    out_dir : Path
        The stage's folder.
    root : Path
        The report's folder.

    Returns
    -------
    dict
        ``topdown`` (image per world), ``manifolds`` (image and frames per manifold),
        ``sheet`` (the samples' sheet) and ``gallery`` (image per family), paths relative to
        ``root``.
    """
    import cv2

    from scenes import build_world
    from sim.topdown import TopDownView

    names = dataset.manifolds  # the label space of the dataset's worlds, from the dataset
    views, result, rows = {}, {"topdown": {}, "manifolds": {}}, {}
    for seq in dataset.sequences.values():
        if seq.world not in views:
            views[seq.world] = TopDownView(build_world(seq.world), max_size=640)
    for world, view in views.items():
        img = view.draw()
        for seq in dataset.sequences.values():
            if seq.world == world:
                pts = np.round(view.to_pixels(seq.poses[:, :2])).astype(np.int32)
                cv2.polylines(img, [pts], False, (40, 40, 200), 2, cv2.LINE_AA)
        path = write_png(out_dir / f"{world}_topdown.png", img)
        result["topdown"][world] = _rel(path, root)
    for m, (seq, frames) in manifold_samples(dataset).items():
        h, middle = seq.images.shape[1], frames[1]
        crop = laser_crop(
            views[seq.world], seq.poses[middle], seq.scans[middle], seq.angles, seq.poses, h
        )
        row = np.concatenate([seq.images[i] for i in frames] + [crop], axis=1)
        path = write_png(out_dir / f"{names[m].replace(':', '-')}_samples.png", row)
        result["manifolds"][names[m]] = {
            "image": _rel(path, root),
            "frames": [[seq.name, i] for i in frames],
        }
        rows.setdefault(seq.world, []).append((names[m], row))
    result["sheet"] = _rel(write_png(out_dir / "samples.png", sample_sheet(rows)), root)
    result["gallery"] = _gallery(out_dir, root)
    return result


def _gallery(out_dir: Path, root: Path) -> dict:
    """Copy the committed galleries of generated worlds beside the report.

    The galleries are ``docs/img/gallery_*.png``, drawn by ``python -m scripts.world_gallery``
    (a test checks they match the generator); drawing 24 worlds would add ~12 s to the run.
    """
    import shutil

    out = {}
    for family in ("hallway", "lawn"):
        source = REPO_ROOT / "docs" / "img" / f"gallery_{family}.png"
        if source.is_file():
            target = out_dir / source.name
            shutil.copyfile(source, target)
            out[family] = _rel(target, root)
    return out


def stage_manifold(dataset_dir: Path, out_dir: Path, root: Path, progress: bool) -> dict:
    """Run the manifold-clustering reproduction (``scripts.manifold``) on the run's dataset.

    Parameters
    ----------
    dataset_dir : Path
        The dataset's folder.
    out_dir : Path
        The stage's folder.
    root : Path
        The report's folder.
    progress : bool
        Whether to show progress.

    Returns
    -------
    dict
        The reproduction's result, its ``figures`` relative to ``root``.
    """
    from scripts.manifold import run_reproduction

    result = run_reproduction(dataset_dir, out_dir, progress=progress)
    result = dict(result)
    result["figures"] = [_rel(out_dir / p, root) for p in result.get("figures", [])]
    return result


def stage_protocol(folder: str | Path | None) -> dict:
    """Read the frozen protocol's per-seed errors from ``folder``.

    They are summarised per condition, features and method. The cells are files from disk:
    ``load_cells`` checks their form. An optional ``meta.json`` of strings (how and at which
    commit the cells were made) is shown beside.

    Parameters
    ----------
    folder : str or Path or None
        ``scripts.manifold.protocol``'s ``--out``, or None.

    Returns
    -------
    dict
        ``source`` (the folder as shown), ``cells`` (their count), ``rows`` (the summary) and
        ``made`` (the ``meta.json``); ``{"source": None, "rows": []}`` without a folder.

    Raises
    ------
    ValueError
        If the folder holds no cells or a ``meta.json`` that is not an object of strings.
    """
    if folder is None:
        return {"source": None, "rows": []}
    from scripts.manifold import load_cells, summarize

    cells = load_cells(Path(folder))
    if not cells:
        raise ValueError(
            f"protocol: {folder} holds no cells/*.json; run python -m scripts.manifold.protocol "
            f"--out {folder} first"
        )
    source = Path(folder).resolve()
    shown = str(source.relative_to(REPO_ROOT)) if source.is_relative_to(REPO_ROOT) else str(folder)
    return {
        "source": shown,
        "cells": len(cells),
        "rows": summarize(cells),
        "made": _protocol_meta(Path(folder) / "meta.json"),
    }


def _protocol_meta(path: Path) -> dict:
    """Read ``meta.json`` beside the cells: a JSON object of short strings, else refused."""
    if not path.is_file():
        return {}
    try:
        data = read_json(path)
    except UnreadableJSON as err:
        raise ValueError(f"{path}: not JSON ({err})") from err
    strings = isinstance(data, dict) and all(
        isinstance(k, str) and isinstance(v, str) and len(v) < 2000 for k, v in data.items()
    )
    if not strings:
        raise ValueError(f"{path}: must be a JSON object of strings (under 2000 characters)")
    return data


def stage_grouping(dataset, out_dir: Path, settings: RunSettings, progress: bool) -> dict:
    """Evaluate the observation grouping (``scripts.grouping.evaluate_grouping``).

    Parameters
    ----------
    dataset : Dataset
        The run's dataset.
    out_dir : Path
        The stage's folder.
    settings : RunSettings
        The run's settings (``grouping_loop``).
    progress : bool
        Whether to show progress.

    Returns
    -------
    dict
        The evaluation's result.
    """
    from scripts.grouping import evaluate_grouping

    return evaluate_grouping(dataset, out_dir, loop=settings.grouping_loop, progress=progress)


def stage_servo(
    data_dir: Path,
    worlds: Sequence[str],
    out_dir: Path,
    root: Path,
    settings: RunSettings,
    maps_dir: Path,
    progress: bool,
) -> dict:
    """Run the servo benchmark's test split (``servo.task.protocol``) for every policy.

    Every policy runs from every start tier, ``settings.episodes`` episodes each, in parallel
    over the cores; videos are of the first policy's own episodes
    (``servo.task.evaluation.evaluate``).

    Parameters
    ----------
    data_dir : Path
        The dataset's folder, which the servo maps are built from.
    worlds : sequence of str
        The worlds.
    out_dir : Path
        The stage's folder.
    root : Path
        The report's folder.
    settings : RunSettings
        The run's settings.
    maps_dir : Path
        The servo map cache.
    progress : bool
        Whether to show progress.

    Returns
    -------
    dict
        ``results`` (one protocol result per world, policy and tier) and ``videos`` (per
        "world/policy", paths relative to ``root``).
    """
    from servo.maps import load_or_build, map_paths
    from servo.task import Protocol, evaluate, run_protocol

    results, videos = [], {}
    for world in worlds:
        servo_map = load_or_build(world, dataset=data_dir, cache=maps_dir)
        path, _ = map_paths(maps_dir, world, servo_map.key)
        for policy in settings.policies:
            controller = policy in ("servo", "signal")
            for tier in settings.tiers if controller else settings.baseline_tiers:
                plot = out_dir / f"{world}-{policy}-{tier}-trajectories.png"
                r = run_protocol(
                    Protocol(world, tier, "test"),
                    path,
                    settings.episodes,
                    policy,
                    progress=progress,
                    plot=plot,
                )
                r["plot"] = _rel(r["plot"], root)
                r.pop("episodes_detail", None)  # report.json keeps the tables, not every step
                results.append(r)
        if settings.videos:
            policy = settings.policies[0]
            evaluate(
                world,
                settings.videos,
                settings.seed,
                policy=policy,
                servo_map=servo_map,
                out=out_dir,
                videos=settings.videos,
                progress=progress,
            )
            found = sorted(out_dir.glob(f"{world}-{policy}-episode*.mp4"))[: settings.videos]
            if found:
                videos[f"{world}/{policy}"] = [_rel(p, root) for p in found]
    return {"results": results, "videos": videos}


def stage_leaderboards(repo: Path = REPO_ROOT) -> dict:
    """Rank the committed leaderboards as ``topomap leaderboard`` ranks them; nothing is run.

    The leaderboards are in ``docs/results/data``: ours beside methods from outside, each run by
    its protocol and kept as result files.

    Parameters
    ----------
    repo : Path, default REPO_ROOT
        The repository's root.

    Returns
    -------
    dict
        ``boards`` (per leaderboard section: task, heading, tables and files) and ``missing``
        (why there are none: an installed package without the repository's docs; else None).
    """
    from scripts.leaderboard import leaderboard_tables, rank
    from scripts.results import SECTIONS, leaderboard_inputs

    data = Path(repo) / "docs" / "results" / "data"
    if not data.is_dir():
        return {"boards": [], "missing": f"no committed result files (no folder {data})"}
    boards = []
    for s in (s for s in SECTIONS if s.renderer == "leaderboard"):
        results, reference = leaderboard_inputs(repo, s.sources)
        tables = [list(t) for t in leaderboard_tables(rank(results, reference), reference)]
        files = sorted({Path(r["_path"]).relative_to(repo).as_posix() for r in results})
        boards.append({"task": s.task, "heading": s.heading, "tables": tables, "files": files})
    return {"boards": boards, "missing": None}
