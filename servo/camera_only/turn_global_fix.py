"""The global fix of the camera-only controller's observing turn.

The turn is [`SignalServo`][servo.camera_only.controller.SignalServo]'s; its fix is checked
across the turn (against a wrong or loose fix).

Every few degrees of the turn the image is localised on its own (the best-aligned view of the
clusters eq. 13 ranks first, `localise`), which gives a
view and the odometry heading that faces the way it looks. The single best match can be a
look-alike far away (the lawn's mirrored arms, a view 12-46 m off on dev starts).

`contrast_fix` (the default) uses the whole turn: every
sample is aligned with every stored view, and a view counts by how sharply its distance
profile over the turn dips (a real place is seen only facing one way; a look-alike that
matches at every heading is not).

`TurnSamples` collects a turn's localisations and gives its fix.
"""

from __future__ import annotations

import numpy as np

from common.geometry import wrap_angle
from servo.camera_only.config import SignalServoConfig
from servo.camera_only.metric_pose_fixes import PoseFixes
from servo.localise import ImageLocaliser


def contrast_fix(
    distances, yaws, headings, *, far: float = 0.6, verify=None, candidates: int = 0
) -> tuple[int, float]:
    """Fix the robot's place from the whole observing turn.

    The fix is the stored view whose best match over the turn stands out most against its
    matches from headings ``far`` rad or more away.

    ``distances`` / ``yaws`` (S, N): every sample's aligned distance to every stored view and
    the heading error of the best shift (`align`);
    ``headings`` (S,): each sample's odometry heading. A view of a real place matches only
    the images taken facing the way it looks (the camera sees ~1 rad; the alignment shifts
    ~0.25 rad either way), so its distance profile over the turn has one sharp dip. A view
    that matches whichever way the camera looks (a close-up of a fence or a wall, open grass
    and sky: the lawn's look-alikes 12-46 m off) has a flat profile. The score is the best
    distance divided by the best from the far headings (smaller: sharper); the fix is the
    view with the smallest, and the odometry heading that faces the way it looks. With
    ``verify`` (view -> bool: the turn's metric support for a fix there,
    `supports`) a fix it does not support gives
    way to the first of the next ``candidates`` views by score that it supports (a look-alike down a
    symmetric corridor matches as well as the place, but keypoints at known depths pose the robot
    only against the place). Returns (view, heading).

    Parameters
    ----------
    distances : array_like of shape (S, N)
        Every sample's aligned (squared) distance to every stored view.
    yaws : array_like of shape (S, N)
        The heading error of each best shift, rad.
    headings : array_like of shape (S,)
        Each sample's odometry heading, rad.
    far : float, default 0.6
        The least heading difference (rad) from a view's best sample that counts as far.
    verify : callable, optional
        View -> bool: whether the turn supports a fix on that view metrically.
    candidates : int, default 0
        How many views after the best by score ``verify`` may try.

    Returns
    -------
    view : int
        The stored view of the fix.
    heading : float
        The odometry heading that faces the way it looks, rad.
    """
    score, facing = contrast_scores(distances, yaws, headings, far=far)
    k = int(np.argmin(score))
    if verify is not None and candidates > 0 and not verify(k):
        order = np.argsort(score, kind="stable")[1 : candidates + 1]
        k = next((int(j) for j in order if np.isfinite(score[j]) and verify(int(j))), k)
    return k, float(facing[k])


def contrast_scores(
    distances, yaws, headings, *, far: float = 0.6
) -> tuple[np.ndarray, np.ndarray]:
    """Score every stored view as `contrast_fix` does.

    Returns two (N,) arrays: each view's score (smaller: its best match over the turn stands
    out more) and the odometry heading that faces the way each looks; arguments as there.

    Parameters
    ----------
    distances : array_like of shape (S, N)
        Every sample's aligned (squared) distance to every stored view.
    yaws : array_like of shape (S, N)
        The heading error of each best shift, rad.
    headings : array_like of shape (S,)
        Each sample's odometry heading, rad.
    far : float, default 0.6
        The least heading difference (rad) from a view's best sample that counts as far.

    Returns
    -------
    score : numpy.ndarray of shape (N,)
        Each view's score (its best distance over its best from far headings).
    heading : numpy.ndarray of shape (N,)
        The odometry heading that faces the way each view looks, rad.
    """
    d = np.asarray(distances, np.float64)
    y = np.asarray(yaws, np.float64)
    h = np.asarray(headings, np.float64)
    if d.ndim != 2 or d.shape != y.shape or h.shape != d.shape[:1] or d.size == 0:
        raise ValueError(
            f"distances and yaws must be (S, N) and headings (S,), not empty; got "
            f"{d.shape}, {y.shape}, {h.shape}"
        )
    cols = np.arange(d.shape[1])
    best = np.argmin(d, axis=0)  # each view's best sample
    d_best = d[best, cols]
    apart = np.abs(wrap_angle(h[:, None] - h[best][None, :])) > far
    d_far = np.where(apart, d, np.inf).min(axis=0)
    # no sample far enough (a short turn): fall back on the distance alone
    score = np.where(np.isfinite(d_far), d_best / np.maximum(d_far, 1e-9), d_best)
    return score, h[best] + y[best, cols]


class TurnSamples:
    """The localisations of one observing turn and the global fix they give.

    Parameters
    ----------
    localiser : ImageLocaliser
        Aligns the turn's images with the map's stored views.
    config : SignalServoConfig
        The controller's settings (``contrast_fix``, ``fix_clusters``, ``fix_far``,
        ``fix_check``).
    poses : PoseFixes or None
        The metric pose fixes, which keep the turn's images to check a fix (None: no check).

    Attributes
    ----------
    samples : list of (float, int, float)
        Each localisation's aligned distance, view and the odometry heading facing it.
    rows : list of (numpy.ndarray, numpy.ndarray, float)
        With ``contrast_fix``: each sample's aligned distances and yaws to every view and its
        odometry heading.
    """

    def __init__(
        self, localiser: ImageLocaliser, config: SignalServoConfig, poses: PoseFixes | None
    ):
        self.localiser, self.config, self.poses = localiser, config, poses
        self.samples: list[tuple[float, int, float]] = []
        self.rows: list[tuple[np.ndarray, np.ndarray, float]] = []

    def observe(self, x: np.ndarray, image: np.ndarray, odometry: np.ndarray) -> None:
        """Localise the image (features ``x``) taken at odometry pose ``odometry``.

        Parameters
        ----------
        x : numpy.ndarray
            The image's features.
        image : numpy.ndarray
            The image itself (H, W, 3) uint8, kept for the metric check.
        odometry : numpy.ndarray
            The odometry pose (x, y, theta) it was taken at.
        """
        c = self.config
        if c.contrast_fix:
            d_all, yaw_all = self.localiser.align(x)
            self.rows.append((d_all, yaw_all, float(odometry[2])))
            if self.poses is not None:
                self.poses.observe(image, odometry)
            k = int(np.argmin(d_all))
            self.samples.append((float(d_all[k]), k, float(odometry[2] + yaw_all[k])))
        else:
            view, yaw, d = self.localiser.localise(x, top=c.fix_clusters)
            self.samples.append((d, view, float(odometry[2] + yaw)))

    def fix(self) -> tuple[int, float]:
        """Return the global fix: `contrast_fix`, or the best match.

        The fix is a view and the odometry heading facing it.

        Returns
        -------
        view : int
            The stored view of the fix.
        heading : float
            The odometry heading that faces the way it looks, rad.
        """
        c = self.config
        if c.contrast_fix:
            d, yaw, h = (np.array(a) for a in zip(*self.rows, strict=True))
            verify = None if self.poses is None else (lambda v: self.poses.supports(v, d[:, v]))
            return contrast_fix(d, yaw, h, far=c.fix_far, verify=verify, candidates=c.fix_check)
        _, view, heading = min(self.samples)
        return view, heading

    def distances(self, view: int) -> np.ndarray:
        """Each ``contrast_fix`` sample's aligned distance to ``view``.

        Parameters
        ----------
        view : int
            The stored view.

        Returns
        -------
        numpy.ndarray of shape (S,)
            Each sample's aligned distance to ``view``, in the turn's order.
        """
        return np.array([r[0][view] for r in self.rows])
