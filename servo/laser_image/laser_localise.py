"""Where the robot is on a `MetricMap`, from laser scans and images.

`GlobalLocaliser` answers from nothing: the scans of a turn on the spot, joined by the
odometry into one all-round scan, are scored against the point map at every free place and
heading (a correlative search on the map's distance field), the best distinct poses refined by
ICP, and the ones the laser cannot tell apart (the arms of a symmetric junction) told apart by
the images taken on the turn: each is compared, shift-aligned, with the stored views near the
candidate pose that look the same way.

`ScanTracker` answers from a prior pose: ICP of the current scan on the point map,
accepted only when most of the scan fits and the correction is small; it reports how well
the scan fits, which tells the controller when it is lost.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy import ndimage

from common.blas import single_threaded_blas
from common.geometry import thin_to_grid, wrap_angle
from mapping.scan_matching import icp
from servo.laser_image.metric_map import FIELD_RESOLUTION, MetricMap
from servo.localise import ImageLocaliser

__all__ = ["Fix", "GlobalLocaliser", "ScanTracker"]


@dataclass(frozen=True)
class Fix:
    """A global fix: a pose on the map and how well the scan and the images support it.

    Parameters
    ----------
    pose : ndarray of shape (3,)
        The pose in the map frame.
    fit : float
        The share of the scan within ``FIT_TOL`` of the map.
    image : float
        The mean aligned image distance to the nearby views (0..4; NaN with no view near).
    margin : float
        The combined score's lead over the runner-up's: how much better this one is.
    """

    pose: np.ndarray
    fit: float
    image: float
    margin: float


FIT_TOL = 0.1  # m: a scan point this close to the map fits
COARSE_TOL = 0.3  # m: the same on the coarse search grid
COARSE_STEP = 0.4  # m between candidate positions
BEYOND_SEEN = 1.5  # m: candidate positions reach this far past the sensed free space ...
CANDIDATE_CLEARANCE = 0.35  # m: ... where no map point is this close
COARSE_YAWS = 72  # headings tried per position
COARSE_POINTS = 80  # scan points scored per candidate
NO_VIEW = 1.5  # aligned image distance charged to a candidate no stored view can vouch for
N_REFINE = 32  # distinct coarse candidates refined by ICP
REFINE_SPACING = 0.1  # m: the all-round cloud thinned to one point per cell for ICP
SCREEN_POINTS = 250  # ... and subsampled to at most this many for a first, short ICP
SCREEN_ITERATIONS = 8  # ... of every candidate,
N_FINAL = 16  # then the best this many by fit refined on the thinned cloud
REFINE_POINTS = 800  # (at most this many points)
REFINE_ITERATIONS = 15
VIEW_RADIUS = 4.0  # m: stored views this near a candidate are compared with the images
FAR_VIEW_RADIUS = 6.0  # m: ... or this near, for a candidate with no view within VIEW_RADIUS
VIEW_HEADING = np.deg2rad(40.0)  # ... when they look within this of the image's heading


def candidate_positions(metric_map: MetricMap) -> np.ndarray:
    """Return the places the robot may be at, on a ``COARSE_STEP`` lattice.

    They are the map's sensed free space and up to ``BEYOND_SEEN`` beyond it (a start may lie
    where no recorded beam went, e.g. behind where a recording began, facing away from it),
    clear of map points.

    Parameters
    ----------
    metric_map : MetricMap
        The map.

    Returns
    -------
    ndarray of shape (k, 2)
        The places in the map frame, m.
    """
    grid = metric_map.grid
    beyond = ndimage.distance_transform_edt(~grid.free) * grid.resolution <= BEYOND_SEEN
    centers = grid.cell_centers()
    ok = beyond & (metric_map.distance(centers) > CANDIDATE_CLEARANCE)
    every = max(1, round(COARSE_STEP / grid.resolution))
    i, j = np.nonzero(ok)
    keep = (i % every == 0) & (j % every == 0)
    return centers[i[keep], j[keep]]


class CoarseField:
    """The map's distance field as a padded 0/1 mask (within ``COARSE_TOL`` of a map point).

    It scores every candidate position under many headings by lookups alone: a rotated scan
    point's offset is rounded to whole cells, so a candidate's score is a sum over the mask
    at its own cell plus those offsets (within half a cell, 2.5 cm, of the exact lookup).
    Points farther than ``reach`` (m) from the robot count as misses.

    Parameters
    ----------
    metric_map : MetricMap
        The map.
    positions : ndarray of shape (k, 2)
        The candidate positions in the map frame, m.
    reach : float
        Largest distance of a scored point from the robot, m.
    """

    def __init__(self, metric_map: MetricMap, positions: np.ndarray, reach: float):
        near = metric_map.field <= COARSE_TOL
        self.pad = int(np.ceil(reach / FIELD_RESOLUTION)) + 1
        self.reach = float(reach)
        h, w = near.shape
        mask = np.zeros((h + 2 * self.pad, w + 2 * self.pad), np.uint8)
        mask[self.pad : self.pad + h, self.pad : self.pad + w] = near
        self._mask, self._width = mask.ravel(), mask.shape[1]
        ij = np.floor((positions - metric_map.origin) / FIELD_RESOLUTION).astype(np.int64)
        base = (ij[:, 1] + self.pad) * self._width + ij[:, 0] + self.pad
        index = np.int32 if mask.size < 2**31 else np.int64
        self._base = base.astype(index)

    def scores(self, points: np.ndarray, yaws: np.ndarray) -> np.ndarray:
        """Return the share of ``points`` near the map, per heading and candidate position.

        Parameters
        ----------
        points : ndarray of shape (M, 2)
            Scan points in the robot frame, m.
        yaws : ndarray of shape (Y,)
            Headings tried, rad.

        Returns
        -------
        ndarray of shape (Y, k), float32
            The share of ``points`` within ``COARSE_TOL`` of a map point.
        """
        inside = points[np.hypot(points[:, 0], points[:, 1]) < self.reach]
        out = np.empty((len(yaws), len(self._base)), np.float32)
        for k, yaw in enumerate(yaws):
            c, s = np.cos(yaw), np.sin(yaw)
            off = np.rint(inside @ np.array([[c, s], [-s, c]]) / FIELD_RESOLUTION).astype(np.int64)
            flat = (off[:, 1] * self._width + off[:, 0]).astype(self._base.dtype)
            out[k] = np.take(self._mask, self._base[:, None] + flat[None, :]).sum(axis=1)
        return out / max(len(points), 1)


class GlobalLocaliser:
    """Global localisation on ``metric_map`` (see the module docstring).

    Parameters
    ----------
    metric_map : MetricMap
        The map.
    images : ImageLocaliser
        Compares images with the map's stored views.
    image_weight : float, default 0.3
        Combined score = fit - ``image_weight`` x mean aligned image distance.
    """

    def __init__(self, metric_map: MetricMap, images: ImageLocaliser, image_weight: float = 0.3):
        self.metric = metric_map
        self.images = images
        self.image_weight = float(image_weight)
        self.positions = candidate_positions(metric_map)
        self._coarse = CoarseField(metric_map, self.positions, metric_map.map.max_range + 1.0)

    def candidates(self, cloud: np.ndarray) -> np.ndarray:
        """Return the distinct poses whose coarse fit of ``cloud`` is best.

        Parameters
        ----------
        cloud : ndarray of shape (M, 2)
            The all-round scan in the robot frame, m.

        Returns
        -------
        ndarray of shape (k, 3)
            Up to ``N_REFINE`` poses in the map frame, best first.
        """
        pts = cloud[:: max(1, len(cloud) // COARSE_POINTS)]
        yaws = np.linspace(-np.pi, np.pi, COARSE_YAWS, endpoint=False)
        scores = self._coarse.scores(pts, yaws)
        order = np.argsort(scores, axis=None)[::-1]
        chosen: list[np.ndarray] = []
        for flat in order[: 50 * N_REFINE]:
            k, p = np.unravel_index(flat, scores.shape)
            pose = np.array([*self.positions[p], yaws[k]])
            # one candidate per place and heading: the next best are its neighbours
            if all(
                np.hypot(*(pose[:2] - q[:2])) > 1.0 or abs(wrap_angle(pose[2] - q[2])) > 0.5
                for q in chosen
            ):
                chosen.append(pose)
                if len(chosen) == N_REFINE:
                    break
        return np.array(chosen)

    def image_distances(self, poses: np.ndarray, views: list) -> np.ndarray:
        """Return, per pose, the mean aligned distance of the turn's images to the stored views.

        For each of ``poses``: the mean over the turn's images of the aligned distance to the
        best stored view near the pose (``VIEW_RADIUS``, or ``FAR_VIEW_RADIUS`` when none is that
        near) looking the image's way. Each image is aligned once, against the stored views any
        of the poses needs.

        Parameters
        ----------
        poses : ndarray of shape (k, 3)
            Candidate poses in the map frame.
        views : list of (ndarray, float)
            The turn's images: features, and heading offset from the pose, rad.

        Returns
        -------
        ndarray of shape (k,)
            The mean distance per pose (NaN: no stored view near looks any image's way).
        """
        poses = np.atleast_2d(poses)
        stored = self.metric.poses
        gap = stored[None, :, :2] - poses[:, None, :2]
        dist = np.hypot(gap[..., 0], gap[..., 1])
        near = dist < VIEW_RADIUS  # (k, views)
        off = ~near.any(axis=1)  # off the recorded paths (wide lawns): look farther
        near[off] = dist[off] < FAR_VIEW_RADIUS
        total, count = np.zeros(len(poses)), np.zeros(len(poses))
        for x, offset in views:
            heading = poses[:, 2, None] + offset
            look = near & (np.abs(wrap_angle(stored[None, :, 2] - heading)) < VIEW_HEADING)
            need = np.flatnonzero(look.any(axis=0))
            if len(need) == 0:
                continue
            d = np.full(len(stored), np.inf)
            d[need] = self.images.align(x, need)[0]
            best = np.where(look, d[None, :], np.inf).min(axis=1)
            seen = np.isfinite(best)
            total[seen] += best[seen]
            count[seen] += 1
        return np.where(count > 0, total / np.maximum(count, 1), np.nan)

    def localise(self, cloud: np.ndarray, views: list[tuple[np.ndarray, float]]) -> Fix:
        """Return the best pose for an all-round scan and the turn's images.

        The cloud is thinned to one point per ``REFINE_SPACING`` cell before ICP (a turn's ~45
        scans overlap: the thinned cloud holds the same walls in a fifth of the points).

        Parameters
        ----------
        cloud : ndarray of shape (M, 2)
            The all-round scan in the robot frame now, m.
        views : list of (ndarray, float)
            The turn's images: features, and heading of the image relative to the robot now,
            rad.

        Returns
        -------
        Fix
            The best pose and its scores.
        """
        thin = thin_to_grid(cloud, REFINE_SPACING)
        with single_threaded_blas():  # small products; spinning BLAS threads only cost
            return self._localise(cloud, thin, views)

    def _localise(self, cloud: np.ndarray, thin: np.ndarray, views: list) -> Fix:
        # a short ICP of a subsample for every candidate, the full one for the best few
        screen = thin[:: max(1, -(-len(thin) // SCREEN_POINTS))]
        poses = np.array(
            [self._icp(screen, init, SCREEN_ITERATIONS) for init in self.candidates(cloud)]
        )
        best = np.argsort(-self.metric.fit(screen, poses, FIT_TOL), kind="stable")[:N_FINAL]
        refine = thin[:: max(1, -(-len(thin) // REFINE_POINTS))]
        poses = np.array([self._icp(refine, poses[k], REFINE_ITERATIONS) for k in best])
        fits = self.metric.fit(refine, poses, FIT_TOL)
        images = np.full(len(poses), np.nan)
        # The laser decides unless it cannot: candidates close to the best fit are the
        # look-alikes (mirrored arms, uniform corridor), and the images decide among them.
        close = np.flatnonzero(fits >= fits.max() - 0.15)
        if len(close) > 1:
            images[close] = self.image_distances(poses[close], views)
        # no stored view near looks the way any image did: as bad as unrelated images
        combined = fits - self.image_weight * np.where(np.isfinite(images), images, NO_VIEW)
        combined[np.setdiff1d(np.arange(len(poses)), close)] = -np.inf
        order = np.argsort(combined)[::-1]
        best = int(order[0])
        runner = combined[order[1]] if len(order) > 1 else -np.inf
        return Fix(
            poses[best], float(fits[best]), float(images[best]), float(combined[best] - runner)
        )

    def _icp(self, points: np.ndarray, init: np.ndarray, iterations: int) -> np.ndarray:
        res = icp(
            points,
            self.metric.points,
            init=init,
            target_tree=self.metric.tree,
            max_iterations=iterations,
        )
        return res.transform if np.isfinite(res.rmse) else np.asarray(init, np.float64)


class ScanTracker:
    """ICP of the current scan on the point map from a predicted pose (see the module doc).

    Parameters
    ----------
    metric_map : MetricMap
        The map.
    max_jump : float, default 0.3
        Largest accepted correction of the position, m.
    max_turn : float, default 0.2
        Largest accepted correction of the heading, rad.
    """

    def __init__(self, metric_map: MetricMap, max_jump: float = 0.3, max_turn: float = 0.2):
        self.metric = metric_map
        self.max_jump, self.max_turn = float(max_jump), float(max_turn)

    def correct(self, points: np.ndarray, predicted: np.ndarray) -> tuple[np.ndarray, float, bool]:
        """Correct a predicted pose by ICP of the scan on the point map.

        Parameters
        ----------
        points : ndarray of shape (M, 2)
            The current scan's points in the robot frame, m.
        predicted : ndarray of shape (3,)
            The predicted pose in the map frame.

        Returns
        -------
        pose : ndarray of shape (3,)
            The corrected pose (or ``predicted`` when the match is not trusted).
        fit : float
            The share of the scan within ``FIT_TOL`` of the map at that pose.
        accepted : bool
            Whether the correction was accepted.
        """
        res = icp(
            points,
            self.metric.points,
            init=predicted,
            target_tree=self.metric.tree,
            max_iterations=20,
            max_correspondence_distance=0.4,
        )
        ok = (
            np.isfinite(res.rmse)
            and res.rmse < 0.08
            and res.n_matches >= 0.5 * len(points)
            and np.hypot(*(res.transform[:2] - predicted[:2])) < self.max_jump
            and abs(wrap_angle(res.transform[2] - predicted[2])) < self.max_turn
        )
        pose = res.transform if ok else np.asarray(predicted, np.float64)
        return pose, float(self.metric.fit(points, pose, FIT_TOL)[0]), bool(ok)
