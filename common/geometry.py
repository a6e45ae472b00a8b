"""SE(2) pose algebra and laser-scan geometry.

Shared by the simulator, the mapping methods and the servo.

Poses are ``(x, y, yaw)`` rows. ``se2_compose(a, b)`` is ``a ⊕ b`` (``b`` expressed in the frame
of ``a``, mapped to the frame ``a`` lives in); ``se2_relative(a, b)`` is ``a ⊖ b``-style
"pose of ``b`` seen from ``a``" (``inverse(a) ⊕ b``). All helpers broadcast over leading axes.
"""

from __future__ import annotations

import numpy as np
from numpy.typing import ArrayLike

__all__ = [
    "circular_mean",
    "scan_to_points",
    "se2_compose",
    "se2_inverse",
    "se2_mean",
    "se2_relative",
    "thin_to_grid",
    "transform_points",
    "wrap_angle",
]


def wrap_angle(theta: ArrayLike) -> np.ndarray:
    """Wrap angles to ``[-pi, pi)``.

    Parameters
    ----------
    theta : array-like
        Angles in radians.

    Returns
    -------
    ndarray
        The angles wrapped, float, of the shape of ``theta``.
    """
    return (np.asarray(theta, dtype=float) + np.pi) % (2.0 * np.pi) - np.pi


def se2_compose(a: ArrayLike, b: ArrayLike) -> np.ndarray:
    """Compose poses, ``a ⊕ b``: the pose ``b`` (given in the frame of ``a``) in ``a``'s parent.

    Parameters
    ----------
    a, b : array-like of shape (..., 3)
        ``(x, y, yaw)`` poses; broadcast over leading axes.

    Returns
    -------
    ndarray of shape (..., 3)
        The composed poses, yaw wrapped to ``[-pi, pi)``.
    """
    a = np.asarray(a, dtype=float)
    b = np.asarray(b, dtype=float)
    c, s = np.cos(a[..., 2]), np.sin(a[..., 2])
    x = a[..., 0] + c * b[..., 0] - s * b[..., 1]
    y = a[..., 1] + s * b[..., 0] + c * b[..., 1]
    return np.stack([x, y, wrap_angle(a[..., 2] + b[..., 2])], axis=-1)


def se2_inverse(a: ArrayLike) -> np.ndarray:
    """Invert poses: ``se2_compose(a, se2_inverse(a))`` is the identity.

    Parameters
    ----------
    a : array-like of shape (..., 3)
        ``(x, y, yaw)`` poses.

    Returns
    -------
    ndarray of shape (..., 3)
        The inverse poses.
    """
    a = np.asarray(a, dtype=float)
    c, s = np.cos(a[..., 2]), np.sin(a[..., 2])
    x = -c * a[..., 0] - s * a[..., 1]
    y = s * a[..., 0] - c * a[..., 1]
    return np.stack([x, y, wrap_angle(-a[..., 2])], axis=-1)


def se2_relative(a: ArrayLike, b: ArrayLike) -> np.ndarray:
    """Return the pose of ``b`` in the frame of ``a`` (the differential pose ``inverse(a) ⊕ b``).

    Parameters
    ----------
    a, b : array-like of shape (..., 3)
        ``(x, y, yaw)`` poses; broadcast over leading axes.

    Returns
    -------
    ndarray of shape (..., 3)
        ``b`` seen from ``a``.
    """
    return se2_compose(se2_inverse(a), b)


def transform_points(pose: ArrayLike, points: ArrayLike) -> np.ndarray:
    """Map ``(M, 2)`` points from the frame of ``pose`` to the frame ``pose`` lives in.

    Parameters
    ----------
    pose : array-like of shape (3,)
        ``(x, y, yaw)`` of the points' frame.
    points : array-like
        Points, reshaped to ``(M, 2)``.

    Returns
    -------
    ndarray of shape (M, 2)
        The points in the parent frame.
    """
    pose = np.asarray(pose, dtype=float)
    points = np.asarray(points, dtype=float).reshape(-1, 2)
    c, s = np.cos(pose[2]), np.sin(pose[2])
    return points @ np.array([[c, s], [-s, c]]) + pose[:2]


def circular_mean(angles: ArrayLike, weights: ArrayLike | None = None) -> float:
    """Return the mean direction of angles: the angle of the (weighted) mean unit vector.

    Parameters
    ----------
    angles : array-like
        Angles in radians.
    weights : array-like, optional
        Weight of each angle; equal weights when None.

    Returns
    -------
    float
        The mean direction in radians, in ``[-pi, pi]``.
    """
    angles = np.asarray(angles, dtype=float)
    w = np.ones_like(angles) if weights is None else np.asarray(weights, dtype=float)
    return float(np.arctan2(np.sum(w * np.sin(angles)), np.sum(w * np.cos(angles))))


def se2_mean(poses: ArrayLike) -> np.ndarray:
    """Average ``(K, 3)`` poses: arithmetic mean translation, circular mean heading.

    Parameters
    ----------
    poses : array-like
        ``(x, y, yaw)`` poses, reshaped to ``(K, 3)``.

    Returns
    -------
    ndarray of shape (3,)
        The mean pose.
    """
    poses = np.asarray(poses, dtype=float).reshape(-1, 3)
    return np.array([poses[:, 0].mean(), poses[:, 1].mean(), circular_mean(poses[:, 2])])


def thin_to_grid(points: ArrayLike, spacing: float) -> np.ndarray:
    """Thin points to one per occupied ``spacing`` cell (the cell's centre).

    A point cloud gathered from overlapping scans, thinned so well-seen walls do not weigh more
    than others.

    Parameters
    ----------
    points : array-like
        Points, reshaped to ``(M, 2)``.
    spacing : float
        Side of the grid cells, in the points' units.

    Returns
    -------
    ndarray of shape (K, 2)
        The centres of the occupied cells.
    """
    points = np.asarray(points, dtype=float).reshape(-1, 2)
    cells = np.unique(np.floor(points / spacing).astype(np.int64), axis=0)
    return (cells + 0.5) * spacing


def scan_to_points(
    ranges: ArrayLike, angles: ArrayLike, max_range: float | None = None
) -> np.ndarray:
    """Convert the returns of one scan to 2-D points in the sensor frame (x forward, y left).

    Parameters
    ----------
    ranges : array-like of shape (n_beams,)
        Ranges in metres; inf (no return), NaN, negative values and, if ``max_range`` is
        given, readings at or beyond it are dropped.
    angles : array-like of shape (n_beams,)
        Beam angles in radians, counter-clockwise from the x axis.
    max_range : float, optional
        Drop readings ``>= max_range`` (sensors that report max range instead of inf).

    Returns
    -------
    ndarray of shape (M, 2), float64, M <= n_beams
        The kept returns as points.
    """
    r = np.asarray(ranges, dtype=np.float64)
    a = np.asarray(angles, dtype=np.float64)
    if r.ndim != 1 or a.shape != r.shape:
        raise ValueError(
            f"ranges and angles must be 1-D of the same length, got {r.shape} and {a.shape}"
        )
    keep = np.isfinite(r) & (r >= 0) & np.isfinite(a)
    if max_range is not None:
        keep &= r < max_range
    r, a = r[keep], a[keep]
    return np.column_stack([r * np.cos(a), r * np.sin(a)])
