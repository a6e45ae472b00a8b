"""Where the robot is on a :class:`~servo.metric_map.MetricMap`, from laser scans and images.

:class:`GlobalLocaliser` answers from nothing: the scans of a turn on the spot, joined by the
odometry into one all-round scan, are scored against the point map at every free place and
heading (a correlative search on the map's distance field), the best distinct poses refined by
ICP, and the ones the laser cannot tell apart (the arms of a symmetric junction) told apart by
the images taken on the turn: each is compared, shift-aligned, with the stored views near the
candidate pose that look the same way.

:class:`ScanTracker` answers from a prior pose: ICP of the current scan on the point map,
accepted only when most of the scan fits and the correction is small; it reports how well
the scan fits, which tells the controller when it is lost.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from common.geometry import wrap_angle
from mapping.icp import icp
from servo.localise import ImageLocaliser
from servo.metric_map import MetricMap

__all__ = ["Fix", "GlobalLocaliser", "ScanTracker"]


@dataclass(frozen=True)
class Fix:
    """A global fix: ``pose`` (map frame), the share of the scan within ``FIT_TOL`` of the
    map (``fit``), the mean aligned image distance to the nearby views (``image``, 0..4; NaN
    with no view near) and the runner-up's combined score (``margin``: how much better this
    one is)."""

    pose: np.ndarray
    fit: float
    image: float
    margin: float


FIT_TOL = 0.1  # m: a scan point this close to the map fits
COARSE_TOL = 0.3  # m: the same on the coarse search grid
COARSE_STEP = 0.4  # m between candidate positions
COARSE_YAWS = 72  # headings tried per position
COARSE_POINTS = 80  # scan points scored per candidate
NO_VIEW = 1.5  # aligned image distance charged to a candidate no stored view can vouch for
N_REFINE = 16  # distinct coarse candidates refined by ICP
VIEW_RADIUS = 4.0  # m: stored views this near a candidate are compared with the images
VIEW_HEADING = np.deg2rad(40.0)  # ... when they look within this of the image's heading


class GlobalLocaliser:
    """Global localisation on ``metric_map`` (see the module docstring).

    ``image_weight``: combined score = fit - ``image_weight`` x mean aligned image distance.
    """

    def __init__(self, metric_map: MetricMap, images: ImageLocaliser, image_weight: float = 0.3):
        self.metric = metric_map
        self.images = images
        self.image_weight = float(image_weight)
        grid = metric_map.grid
        every = max(1, round(COARSE_STEP / grid.resolution))
        i, j = np.nonzero(grid.free)
        keep = (i % every == 0) & (j % every == 0)
        self.positions = grid.cell_centers()[i[keep], j[keep]]

    def candidates(self, cloud: np.ndarray) -> np.ndarray:
        """(k, 3) distinct poses whose coarse fit of ``cloud`` (robot frame) is best."""
        pts = cloud[:: max(1, len(cloud) // COARSE_POINTS)]
        yaws = np.linspace(-np.pi, np.pi, COARSE_YAWS, endpoint=False)
        scores = np.empty((len(yaws), len(self.positions)), np.float32)
        for k, yaw in enumerate(yaws):
            c, s = np.cos(yaw), np.sin(yaw)
            rotated = pts @ np.array([[c, s], [-s, c]])
            d = self.metric.distance(self.positions[:, None, :] + rotated[None, :, :])
            scores[k] = (d <= COARSE_TOL).mean(axis=1)
        order = np.argsort(scores, axis=None)[::-1]
        chosen: list[np.ndarray] = []
        for flat in order[: 50 * N_REFINE]:
            k, p = np.unravel_index(flat, scores.shape)
            pose = np.array([*self.positions[p], yaws[k]])
            # one candidate per place and heading: the next best are its neighbours
            if all(np.hypot(*(pose[:2] - q[:2])) > 1.0 or abs(wrap_angle(pose[2] - q[2])) > 0.5
                   for q in chosen):  # fmt: skip
                chosen.append(pose)
                if len(chosen) == N_REFINE:
                    break
        return np.array(chosen)

    def image_distance(self, pose: np.ndarray, views: list[tuple[np.ndarray, float]]) -> float:
        """Mean over the turn's images (features, heading offset from ``pose``) of the aligned
        distance to the best stored view near ``pose`` looking the image's way (NaN: none)."""
        near = np.hypot(*(self.metric.poses[:, :2] - pose[:2]).T) < VIEW_RADIUS
        out = []
        for x, offset in views:
            heading = pose[2] + offset
            look = near & (np.abs(wrap_angle(self.metric.poses[:, 2] - heading)) < VIEW_HEADING)
            if look.any():
                d, _ = self.images.align(x, np.flatnonzero(look))
                out.append(float(d.min()))
        return float(np.mean(out)) if out else float("nan")

    def localise(self, cloud: np.ndarray, views: list[tuple[np.ndarray, float]]) -> Fix:
        """The best pose for an all-round ``cloud`` (robot frame, now) and the turn's images
        ``views`` (features, heading of the image relative to the robot now)."""
        fits, poses = [], []
        for init in self.candidates(cloud):
            res = icp(cloud, self.metric.points, init=init, target_tree=self.metric.tree,
                      max_iterations=30)  # fmt: skip
            pose = res.transform if np.isfinite(res.rmse) else init
            poses.append(pose)
            fits.append(float(self.metric.fit(cloud, pose, FIT_TOL)[0]))
        fits = np.array(fits)
        images = np.full(len(poses), np.nan)
        # The laser decides unless it cannot: candidates close to the best fit are the
        # look-alikes (mirrored arms, uniform corridor), and the images decide among them.
        close = np.flatnonzero(fits >= fits.max() - 0.15)
        for k in close:
            images[k] = self.image_distance(poses[k], views)
        # no stored view near looks the way any image did: as bad as unrelated images
        combined = fits - self.image_weight * np.where(np.isfinite(images), images, NO_VIEW)
        combined[np.setdiff1d(np.arange(len(poses)), close)] = -np.inf
        order = np.argsort(combined)[::-1]
        best = int(order[0])
        runner = combined[order[1]] if len(order) > 1 else -np.inf
        return Fix(poses[best], float(fits[best]), float(images[best]),
                   float(combined[best] - runner))  # fmt: skip


class ScanTracker:
    """ICP of the current scan on the point map from a predicted pose (see the module doc)."""

    def __init__(self, metric_map: MetricMap, max_jump: float = 0.3, max_turn: float = 0.2):
        self.metric = metric_map
        self.max_jump, self.max_turn = float(max_jump), float(max_turn)

    def correct(self, points: np.ndarray, predicted: np.ndarray) -> tuple[np.ndarray, float, bool]:
        """(pose, fit, accepted): the corrected pose (or ``predicted`` when the match is not
        trusted), the share of the scan within ``FIT_TOL`` of the map at that pose, and
        whether the correction was accepted."""
        res = icp(points, self.metric.points, init=predicted, target_tree=self.metric.tree,
                  max_iterations=20, max_correspondence_distance=0.4)  # fmt: skip
        ok = (
            np.isfinite(res.rmse)
            and res.rmse < 0.08
            and res.n_matches >= 0.5 * len(points)
            and np.hypot(*(res.transform[:2] - predicted[:2])) < self.max_jump
            and abs(wrap_angle(res.transform[2] - predicted[2])) < self.max_turn
        )
        pose = res.transform if ok else np.asarray(predicted, np.float64)
        return pose, float(self.metric.fit(points, pose, FIT_TOL)[0]), bool(ok)
