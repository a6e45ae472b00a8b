"""Several drives (runs) through one place, concatenated in the form the mapping methods take.

[`sim.dataset.Dataset.runs`][sim.dataset.model.Dataset.runs] builds one; ``groups`` is the
per-sample drive index that
[`mapping.ObservationGraphPartitioner`][mapping.grouping.partitioner.ObservationGraphPartitioner]
takes (scikit-learn's ``groups`` convention, as in ``GroupKFold``), so the grouping of a dataset's
laser scans is::

    runs = dataset.runs("hallway")
    ObservationGraphPartitioner().fit(runs.scans, runs.odometry, groups=runs.groups)
"""

from __future__ import annotations

from collections.abc import Sequence as SequenceOf
from dataclasses import dataclass
from typing import TYPE_CHECKING

import numpy as np

from common.geometry import scan_to_points

if TYPE_CHECKING:
    from sim.dataset import Sequence


@dataclass(frozen=True)
class Runs:
    """The sequences (drives) of one world, concatenated frame by frame.

    Attributes
    ----------
    world : str
        The world (place) they were recorded in.
    names : list of str
        The sequences, in order.
    groups : ndarray of int, shape (N,)
        Per frame, the index of its sequence in ``names`` (the drive it belongs to).
    ranges : ndarray of float32, shape (N, B)
        The raw laser ranges (``inf``: no return), e.g. for ``ScanFeatures``.
    scans : list of ndarray of shape (M_i, 2)
        Per frame, the returns as points in the sensor frame (x forward, y left); beams with no
        return, and readings at or beyond ``max_range``, are left out.
    max_range : float
        The laser's maximum range: the dataset's setting, else the longest return seen.
    odometry : ndarray of shape (N, 3)
        Odometry poses (x, y, yaw), each drive in its own odometry frame.
    images : ndarray of uint8, shape (N, H, W, 3), or None
        The RGB camera frames; None for drives recorded without a camera.
    times : ndarray of shape (N,)
        Seconds since each drive's start.
    poses : ndarray of shape (N, 3) or None
        The true poses; None without ground truth (imported robot logs).
    labels : ndarray of int, shape (N,) or None
        The ground-truth manifold ids (-1: on none); None without ground truth.
    manifold_names : tuple of str or None
        The manifold of each id (the dataset's ``manifolds``); None for recordings without
        labels.

    Parameters
    ----------
    world, names, groups, ranges, scans, max_range, odometry, images, times
        The attributes above, as ``from_sequences`` makes them.
    poses, labels, manifold_names : optional
        The attributes above; None without ground truth.
    """

    world: str
    names: list[str]
    groups: np.ndarray
    ranges: np.ndarray
    scans: list[np.ndarray]
    max_range: float
    odometry: np.ndarray
    images: np.ndarray | None
    times: np.ndarray
    poses: np.ndarray | None = None
    labels: np.ndarray | None = None
    manifold_names: tuple[str, ...] | None = None

    @classmethod
    def from_sequences(
        cls, sequences: SequenceOf[Sequence], max_range: float | None, manifold_names=None
    ) -> Runs:
        """Concatenate ``sequences`` (all of one world, with the same beam count and image size).

        Parameters
        ----------
        sequences : sequence of Sequence
            The drives, in order.
        max_range : float or None
            The laser's maximum range, m; None: the longest return seen stands for it.
        manifold_names : sequence of str, optional
            The names of the label ids.

        Returns
        -------
        Runs
            The drives concatenated.
        """
        if not sequences:
            raise ValueError("sequences is empty")
        worlds = {s.world for s in sequences}
        if len(worlds) != 1:
            raise ValueError(f"sequences of several worlds given: {sorted(worlds)}")
        camera = all(s.images is not None for s in sequences)
        for field in ("scans", "images") if camera else ("scans",):
            shapes = {s.name: getattr(s, field).shape[1:] for s in sequences}
            if len(set(shapes.values())) != 1:
                raise ValueError(f"the sequences' {field} differ in shape: {shapes}")
        ranges = np.concatenate([s.scans for s in sequences])
        if max_range is None:
            finite = ranges[np.isfinite(ranges)]
            max_range = float(finite.max()) if finite.size else 1.0
            keep_below = None  # the longest return is a return: keep it
        else:
            keep_below = max_range = float(max_range)
        truth = all(s.poses is not None and s.labels is not None for s in sequences)
        return cls(
            world=sequences[0].world,
            names=[s.name for s in sequences],
            groups=np.repeat(np.arange(len(sequences)), [len(s) for s in sequences]),
            ranges=ranges,
            scans=[scan_to_points(r, s.angles, keep_below) for s in sequences for r in s.scans],
            max_range=max_range,
            odometry=np.concatenate([s.odometry for s in sequences]),
            images=np.concatenate([s.images for s in sequences]) if camera else None,
            times=np.concatenate([s.times for s in sequences]),
            poses=np.concatenate([s.poses for s in sequences]) if truth else None,
            labels=np.concatenate([s.labels for s in sequences]).astype(int) if truth else None,
            manifold_names=None if manifold_names is None else tuple(manifold_names),
        )

    @property
    def has_ground_truth(self) -> bool:
        """Whether the drives have true poses and labels."""
        return self.labels is not None

    def __len__(self) -> int:
        """Return the number of frames."""
        return len(self.groups)
