"""A top-down map a person wants to look at: manifold regions in colour, obstacles, the robot,
its laser and its trail. Pure numpy/OpenCV drawing (no GL), so it is cheap and works anywhere.
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
    """The colour of each of ``world``'s manifolds on a map (RGB)."""
    return {
        name: MANIFOLD_COLOURS.get(name, GENERATED_COLOURS[i % len(GENERATED_COLOURS)])
        for name, i in world.manifold_ids.items()
    }


class TopDownView:
    """Draws one world from above at ``pixels_per_metre``; ``draw(...)`` returns RGB uint8."""

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
        """The map with, optionally, a trail (k, 2), a target pose, the robot and its scan."""
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
        """Draw the robot at ``pose`` (x, y, yaw) on ``img`` in place: a disc of its radius
        (only the outline with ``outline_only``, as for a target) and a heading tick.
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
