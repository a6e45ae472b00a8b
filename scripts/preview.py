"""Preview images of a dataset: a contact sheet per sequence and a trajectory map per world."""

from __future__ import annotations

from pathlib import Path

import cv2
import numpy as np

from common.fileio import write_png
from scenes import build_world
from sim.dataset import Dataset
from sim.topdown import MANIFOLD_COLOURS, TopDownView, manifold_colours

THUMB = (160, 120)


def contact_sheet(
    images: np.ndarray,
    labels: np.ndarray,
    names,
    every: int = 10,
    columns: int = 5,
    colours=MANIFOLD_COLOURS,
) -> np.ndarray:
    """Draw thumbnails of every ``every``-th frame, each captioned with its index and manifold.

    Parameters
    ----------
    images : ndarray of shape (n, h, w, 3)
        The frames.
    labels : ndarray of shape (n,)
        Their manifold ids (negative: none).
    names : sequence of str
        The names of the label ids: the dataset's manifolds.
    every : int, default 10
        The step between frames shown.
    columns : int, default 5
        Thumbnails per row.
    colours : dict, default MANIFOLD_COLOURS
        The caption colour of each name.

    Returns
    -------
    ndarray of uint8
        The sheet.
    """
    idx = np.arange(0, len(images), every)
    rows = int(np.ceil(len(idx) / columns))
    w, h = THUMB
    sheet = np.full((rows * (h + 18), columns * w, 3), 255, np.uint8)
    for k, i in enumerate(idx):
        r, c = divmod(k, columns)
        y0, x0 = r * (h + 18), c * w
        sheet[y0 : y0 + h, x0 : x0 + w] = cv2.resize(images[i], THUMB, interpolation=cv2.INTER_AREA)
        name = names[labels[i]] if labels[i] >= 0 else "none"
        colour = colours.get(name, (0, 0, 0))
        sheet[y0 + h : y0 + h + 18, x0 : x0 + w] = colour
        cv2.putText(
            sheet,
            f"{i}: {name}",
            (x0 + 4, y0 + h + 13),
            cv2.FONT_HERSHEY_SIMPLEX,
            0.4,
            (0, 0, 0),
            1,
            cv2.LINE_AA,
        )
    return sheet


def write_previews(dataset: Dataset, out: str | Path) -> list[Path]:
    """Write contact sheets, first/middle/last frames and a trajectory map per world.

    Parameters
    ----------
    dataset : Dataset
        The dataset.
    out : str or Path
        The folder, created when missing.

    Returns
    -------
    list of Path
        The images written.
    """
    out = Path(out)
    out.mkdir(parents=True, exist_ok=True)
    written = []
    by_world: dict[str, list] = {}
    names = dataset.manifolds
    worlds = {w: build_world(w) for w in dict.fromkeys(s.world for s in dataset.sequences.values())}
    colours = {n: c for w in worlds.values() for n, c in manifold_colours(w).items()}
    for name, seq in dataset.sequences.items():
        by_world.setdefault(seq.world, []).append(seq)
        stem = name.replace(":", "-")  # a generated world's name holds a colon
        path = out / f"{stem}_contact_sheet.png"
        write_png(path, contact_sheet(seq.images, seq.labels, names, colours=colours))
        written.append(path)
        frames = [seq.images[i] for i in (0, len(seq) // 2, len(seq) - 1)]
        path = out / f"{stem}_frames.png"
        write_png(path, np.concatenate(frames, axis=1))
        written.append(path)
    for world_name, seqs in by_world.items():
        view = TopDownView(worlds[world_name], max_size=640)
        img = view.draw()
        for seq in seqs:
            pts = np.round(view.to_pixels(seq.poses[:, :2])).astype(np.int32)
            odo = np.round(view.to_pixels(seq.odometry[:, :2])).astype(np.int32)
            cv2.polylines(img, [odo], False, (150, 150, 150), 1, cv2.LINE_AA)
            for p, lab in zip(pts, seq.labels, strict=True):
                colour = (
                    (40, 40, 40)
                    if lab < 0
                    else tuple(int(v * 0.6) for v in colours.get(names[lab], (90, 90, 90)))
                )
                cv2.circle(img, tuple(int(v) for v in p), 2, colour, -1, cv2.LINE_AA)
        path = out / f"{world_name.replace(':', '-')}_trajectories.png"
        write_png(path, img)
        written.append(path)
    return written
