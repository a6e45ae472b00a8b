"""Drawing for the ``worlds`` stage: per manifold sample frames, the laser scan
on a crop of the map, and the contact sheet of the samples.
"""

from __future__ import annotations

import numpy as np

__all__ = ["laser_crop", "manifold_samples", "sample_sheet"]


def manifold_samples(dataset) -> dict[int, tuple]:
    """Per manifold id: (sequence, three frame indices spread over the frames on it, at 1/6,
    1/2 and 5/6) from the sequence with the most frames on it.
    """
    best: dict[int, tuple] = {}
    for seq in dataset.sequences.values():
        for m in np.unique(seq.labels[seq.labels >= 0]):
            idx = np.flatnonzero(seq.labels == m)
            if len(idx) > len(best.get(int(m), (None, []))[1]):
                best[int(m)] = (seq, idx)
    return {
        m: (seq, [int(idx[len(idx) * k // 6]) for k in (1, 3, 5)])
        for m, (seq, idx) in sorted(best.items())
    }


def laser_crop(view, pose, scan, angles, trail, size: int, half_m: float = 8.0) -> np.ndarray:
    """A ``size`` x ``size`` square of the map, ``2 half_m`` metres wide, centred on the robot,
    with its trail, its laser rays (every 8th) and hits in red.
    """
    import cv2

    img = view.draw(pose=pose, trail=trail)
    ok = np.isfinite(scan)
    a = pose[2] + np.asarray(angles)[ok]
    hits = pose[:2] + np.asarray(scan)[ok, None] * np.stack([np.cos(a), np.sin(a)], axis=1)
    c = np.round(view.to_pixels(pose[:2])).astype(int)
    px = np.round(view.to_pixels(hits)).astype(int)
    for p in px[::8]:
        cv2.line(img, tuple(c), tuple(p), (240, 120, 120), 1, cv2.LINE_AA)
    for p in px:
        cv2.circle(img, tuple(p), 2, (220, 20, 20), -1)
    view.draw_robot(img, pose, (30, 30, 30))
    half = int(half_m * view.scale)
    img = cv2.copyMakeBorder(img, half, half, half, half, cv2.BORDER_CONSTANT, value=(60,) * 3)
    crop = img[c[1] : c[1] + 2 * half, c[0] : c[0] + 2 * half]
    return cv2.resize(crop, (size, size), interpolation=cv2.INTER_AREA)


def sample_sheet(rows: dict[str, list[tuple[str, np.ndarray]]], scale: float = 0.5) -> np.ndarray:
    """The manifolds' sample rows at ``scale``, one column per world, each row labelled."""
    import cv2

    columns = []
    for named in rows.values():
        labelled = []
        for name, row in named:
            small = cv2.resize(row, None, fx=scale, fy=scale, interpolation=cv2.INTER_AREA)
            cv2.rectangle(small, (0, 0), (8 + 8 * len(name), 18), (255, 255, 255), -1)
            cv2.putText(
                small, name, (4, 13), cv2.FONT_HERSHEY_SIMPLEX, 0.45, (0, 0, 0), 1, cv2.LINE_AA
            )
            labelled.append(small)
        columns.append(np.concatenate(labelled, axis=0))
    height = max(c.shape[0] for c in columns)
    padded = [
        np.pad(c, ((0, height - c.shape[0]), (0, 6), (0, 0)), constant_values=255) for c in columns
    ]
    return np.concatenate(padded, axis=1)[:, :-6]
