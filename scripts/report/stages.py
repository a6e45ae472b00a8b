"""The report's stages proper: each runs one part of the evaluation into its own folder of
the report and returns a plain dict for its section (paths relative to the report's root).
:mod:`scripts.report.pipeline` wraps them as named stages."""

from __future__ import annotations

from collections.abc import Sequence
from pathlib import Path

import numpy as np

from common.fileio import write_png
from scripts.report.drawing import laser_crop, manifold_samples, sample_sheet
from scripts.report.settings import RunSettings

__all__ = ["stage_grouping", "stage_manifold", "stage_servo", "stage_worlds"]


def _rel(path, root: Path) -> str:
    """``path`` relative to the report root (paths may come absolute or relative to it)."""
    p = Path(path)
    return (p.resolve().relative_to(root.resolve()) if p.is_absolute() else p).as_posix()


def stage_worlds(dataset, out_dir: Path, root: Path) -> dict:
    """Top-down views with trajectories, and per manifold camera frames beside the laser."""
    import cv2

    from scenes import MANIFOLDS, build_world
    from sim.topdown import TopDownView

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
        path = write_png(out_dir / f"{MANIFOLDS[m]}_samples.png", row)
        result["manifolds"][MANIFOLDS[m]] = {
            "image": _rel(path, root),
            "frames": [[seq.name, i] for i in frames],
        }
        rows.setdefault(seq.world, []).append((MANIFOLDS[m], row))
    result["sheet"] = _rel(write_png(out_dir / "samples.png", sample_sheet(rows)), root)
    return result


def stage_manifold(dataset_dir: Path, out_dir: Path, root: Path, progress: bool) -> dict:
    from scripts.reproduce_manifold import reproduce

    result = reproduce(dataset_dir, out_dir, progress=progress)
    result = dict(result)
    result["figures"] = [_rel(out_dir / p, root) for p in result.get("figures", [])]
    return result


def stage_grouping(dataset, out_dir: Path, settings: RunSettings, progress: bool) -> dict:
    from scripts.eval_grouping import evaluate_grouping

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
    from servo.evaluate import evaluate
    from servo.map_store import load_or_build

    results, videos = [], {}
    for world in worlds:
        servo_map = load_or_build(world, dataset=data_dir, cache=maps_dir)
        for policy in settings.policies:
            n_videos = settings.videos if policy == settings.policies[0] else 0
            r = evaluate(
                world,
                settings.episodes,
                settings.seed,
                policy=policy,
                servo_map=servo_map,
                out=out_dir,
                videos=n_videos,
                progress=progress,
            )
            if r.get("plot"):
                r["plot"] = _rel(r["plot"], root)
            results.append(r)
            found = sorted(out_dir.glob(f"{world}-{policy}-episode*.mp4"))[:n_videos]
            if found:
                videos[f"{world}/{policy}"] = [_rel(p, root) for p in found]
    return {"results": results, "videos": videos}
