"""Drawing for the ``worlds`` stage.

Per manifold sample frames, the laser scan on a crop of the map, and the contact sheet of the
samples.
"""

from __future__ import annotations

import numpy as np

__all__ = ["laser_crop", "manifold_samples", "sample_sheet"]


def manifold_samples(dataset) -> dict[int, tuple]:
    """Pick three sample frames per manifold from the sequence with the most frames on it.

    Parameters
    ----------
    dataset : Dataset
        The dataset.

    Returns
    -------
    dict of int to tuple
        Per manifold id: (sequence, three frame indices spread over the frames on it, at 1/6,
        1/2 and 5/6).
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
    """Draw a square of the map centred on the robot, with its trail, laser rays and hits.

    The rays (every 8th) and the hits are drawn in red.

    Parameters
    ----------
    view : TopDownView
        The world's top-down view.
    pose : ndarray of shape (3,)
        The robot's pose (x, y in metres, yaw in radians).
    scan : ndarray of shape (beams,)
        The laser ranges in metres (non-finite: no return).
    angles : array_like of shape (beams,)
        The beams' angles relative to the robot, in radians.
    trail : ndarray
        The robot's past positions, drawn as its trail.
    size : int
        Pixels per side of the result.
    half_m : float, default 8.0
        Half the square's width, in metres.

    Returns
    -------
    ndarray of uint8 of shape (size, size, 3)
        The crop.
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
    """Lay out the manifolds' sample rows at ``scale``, one column per world, each row labelled.

    Parameters
    ----------
    rows : dict of str to list of tuple of (str, ndarray)
        Per world: (manifold name, image row) pairs.
    scale : float, default 0.5
        The rows' scale.

    Returns
    -------
    ndarray of uint8
        The sheet.
    """
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
