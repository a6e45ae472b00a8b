"""A top-down map a person wants to look at.

Manifold regions in colour, obstacles, the robot, its laser and its trail. Pure numpy/OpenCV
drawing (no GL), so it is cheap and works anywhere.
"""

from __future__ import annotations

import cv2
import numpy as np

from scenes import World

# One colour per manifold (RGB), main manifolds darker than their branches.
MANIFOLD_COLOURS = {
    "hallway": (190, 190, 215),
    "hallway-left": (240, 190, 170),
    "hallway-straight": (170, 205, 240),
    "hallway-right": (175, 225, 185),
    "lawn": (175, 220, 160),
    "lawn-left": (205, 205, 205),
    "lawn-straight": (225, 210, 170),
    "lawn-right": (235, 235, 200),
}
# A generated world's manifolds take these in the order of their ids (pale, tellable apart).
GENERATED_COLOURS = (
    (190, 190, 215),
    (240, 190, 170),
    (170, 205, 240),
    (175, 225, 185),
    (235, 215, 160),
    (215, 180, 225),
    (160, 220, 215),
    (230, 230, 190),
    (205, 205, 205),
    (240, 200, 210),
    (190, 215, 160),
    (200, 185, 160),
)


def manifold_colours(world: World) -> dict[str, tuple[int, int, int]]:
    """Return the colour of each of ``world``'s manifolds on a map (RGB).

    Parameters
    ----------
    world : scenes.World
        The world.

    Returns
    -------
    dict of str to tuple of int
        Manifold name -> RGB colour.
    """
    return {
        name: MANIFOLD_COLOURS.get(name, GENERATED_COLOURS[i % len(GENERATED_COLOURS)])
        for name, i in world.manifold_ids.items()
    }


class TopDownView:
    """Draws one world from above; ``draw(...)`` returns RGB uint8.

    Parameters
    ----------
    world : scenes.World
        The world.
    max_size : int, default 480
        The map's longer side, pixels.
    margin : float, default 1.0
        Space around the world's bounds, m.
    """

    def __init__(self, world: World, max_size: int = 480, margin: float = 1.0):
        self.world = world
        xmin, xmax, ymin, ymax = world.bounds
        self.origin = (xmin - margin, ymax + margin)
        self.scale = max_size / max(xmax - xmin + 2 * margin, ymax - ymin + 2 * margin)
        self.size = (
            int(np.ceil((ymax - ymin + 2 * margin) * self.scale)),
            int(np.ceil((xmax - xmin + 2 * margin) * self.scale)),
        )
        self._background = self._draw_background()

    def to_pixels(self, xy) -> np.ndarray:
        """Map world points to pixel coordinates ``(u, v)`` of the map.

        Parameters
        ----------
        xy : array-like of shape (..., 2)
            Points in the world frame, m.

        Returns
        -------
        ndarray of shape (..., 2)
            Pixel coordinates (column, row), float.
        """
        xy = np.asarray(xy, np.float64)
        u = (xy[..., 0] - self.origin[0]) * self.scale
        v = (self.origin[1] - xy[..., 1]) * self.scale
        return np.stack([u, v], axis=-1)

    def _draw_background(self) -> np.ndarray:
        h, w = self.size
        u, v = np.meshgrid(np.arange(w) + 0.5, np.arange(h) + 0.5)
        xy = np.stack([self.origin[0] + u / self.scale, self.origin[1] - v / self.scale], axis=-1)
        labels = self.world.manifold_at(xy)
        img = np.full((h, w, 3), 60, np.uint8)
        ids = self.world.manifold_ids
        for name, colour in manifold_colours(self.world).items():
            img[labels == ids[name]] = colour
        for fp in self.world.footprints:
            img[fp.covers(xy)] = (90, 80, 70)
        return img

    def draw(self, pose=None, scan=None, angles=None, trail=None, target=None) -> np.ndarray:
        """Draw the map with, optionally, a trail, a target pose, the robot and its scan.

        Parameters
        ----------
        pose : array-like of shape (3,), optional
            The robot's pose ``(x, y, yaw)``.
        scan : ndarray of shape (beams,), optional
            Its ranges, m (non-finite ones are not drawn); drawn with ``angles`` and ``pose``.
        angles : ndarray of shape (beams,), optional
            The beams' angles in the sensor frame, rad.
        trail : array-like of shape (k, 2) or (k, 3), optional
            Past positions.
        target : array-like of shape (3,), optional
            A pose drawn in outline.

        Returns
        -------
        ndarray of shape (H, W, 3), uint8
            The RGB map.
        """
        img = self._background.copy()
        s = self.scale
        if trail is not None and len(trail) > 1:
            pts = np.round(self.to_pixels(np.asarray(trail)[:, :2])).astype(np.int32)
            cv2.polylines(img, [pts], False, (40, 40, 200), max(1, int(s * 0.05)), cv2.LINE_AA)
        if target is not None:
            self.draw_robot(img, target, (220, 40, 40), outline_only=True)
        if pose is not None:
            if scan is not None and angles is not None:
                ok = np.isfinite(scan)
                a = pose[2] + np.asarray(angles)[ok]
                r = np.asarray(scan)[ok]
                hits = np.stack([pose[0] + r * np.cos(a), pose[1] + r * np.sin(a)], axis=1)
                px = np.round(self.to_pixels(hits)).astype(np.int32)
                inside = (
                    (px[:, 0] >= 0)
                    & (px[:, 0] < img.shape[1])
                    & (px[:, 1] >= 0)
                    & (px[:, 1] < img.shape[0])
                )
                img[px[inside, 1], px[inside, 0]] = (230, 30, 30)
            self.draw_robot(img, pose, (30, 30, 30))
        return img

    def draw_robot(self, img, pose, colour, outline_only: bool = False) -> None:
        """Draw the robot at ``pose`` (x, y, yaw) on ``img`` in place.

        A disc of its radius (only the outline with ``outline_only``, as for a target) and a
        heading tick.

        Parameters
        ----------
        img : ndarray of shape (H, W, 3), uint8
            The map to draw on.
        pose : array-like of shape (3,)
            The pose ``(x, y, yaw)``.
        colour : tuple of int
            RGB colour.
        outline_only : bool, default False
            Draw only the disc's outline.
        """
        from scenes.robot import RADIUS

        c = np.round(self.to_pixels(pose[:2])).astype(int)
        r = max(2, round(RADIUS * self.scale))
        cv2.circle(img, tuple(c), r, colour, 1 if outline_only else -1, cv2.LINE_AA)
        tip = self.to_pixels(
            np.asarray(pose[:2]) + 2 * RADIUS * np.array([np.cos(pose[2]), np.sin(pose[2])])
        )
        cv2.line(
            img, tuple(c), tuple(np.round(tip).astype(int)), colour, max(1, r // 3), cv2.LINE_AA
        )
