"""Camera-only localisation against a servo map's stored views.

``ImageLocaliser`` compares the current image with stored views in the map's feature space
(``ImageFeatures``: a small unit-normalised image), each comparison minimised over horizontal
shifts: a heading offset moves the scene sideways in the image, so the best shift is the
heading error toward that view (view-sequence navigation's image alignment), and the
residual says how alike the places are. The clustering's eq. 13 (``predict`` / F^j(k)) names
the manifold, and :meth:`ImageLocaliser.signal` is F toward one stored view.
"""

from __future__ import annotations

import numpy as np

from common.geometry import se2_relative
from servo.map_types import ServoMap

MAX_SHIFT = 20  # feature-image pixels tried either way (80 px across the 58 deg camera)
HFOV = 2.0 * np.arctan(np.tan(np.deg2rad(45.0) / 2) * 4.0 / 3.0)  # rad, 320x240 at fovy 45


class ImageLocaliser:
    """Shift-aligned image distances and F^j(k) toward stored views (see the module doc).

    Parameters
    ----------
    servo_map : ServoMap
    max_shift : int
        Horizontal shifts tried, in feature-image pixels either way.
    """

    def __init__(self, servo_map: ServoMap, max_shift: int = MAX_SHIFT):
        if not isinstance(servo_map, ServoMap):
            raise TypeError(f"servo_map must be a ServoMap, got {type(servo_map).__name__}")
        w, h = servo_map.settings.image_size
        if not 0 < int(max_shift) < w // 2:
            raise ValueError(f"max_shift must be in (0, {w // 2}) pixels, got {max_shift}")
        self.map, self.max_shift, self._wh = servo_map, int(max_shift), (w, h)
        self.radians_per_pixel = HFOV / w
        self._views = self._crops(self._images(servo_map.features), 0)
        self._f_view = np.ones(len(servo_map))
        self._f_cache: dict[int, float] = {}

    # -- helpers ----------------------------------------------------------------------------
    def _images(self, X: np.ndarray) -> np.ndarray:
        w, h = self._wh
        return np.asarray(X, np.float32).reshape(len(X), h, w, -1)

    def _crops(self, images: np.ndarray, shift: int) -> np.ndarray:
        """Central columns moved by ``shift`` pixels, zero-mean and unit-norm per image."""
        s = self.max_shift
        w = images.shape[2] - 2 * s
        c = images[:, :, s + shift : s + shift + w].reshape(len(images), -1)
        c = c - c.mean(axis=1, keepdims=True)
        return c / np.maximum(np.linalg.norm(c, axis=1, keepdims=True), 1e-12)

    # -- API --------------------------------------------------------------------------------
    def features(self, image, name: str = "observation['image']") -> np.ndarray:
        """The image's feature vector (d,); refuses a wrong shape or non-finite pixels."""
        image = np.asarray(image)
        if image.shape != self.map.image_shape:
            raise ValueError(f"{name} must have shape {self.map.image_shape}, got {image.shape}")
        if not np.all(np.isfinite(image)):
            raise ValueError(f"{name} must be finite (no NaN or inf)")
        return self.map.image_features.transform(image[None]).astype(np.float32)[0]

    def align(self, x: np.ndarray, views=None, step: int = 2) -> tuple[np.ndarray, np.ndarray]:
        """Squared distance (0..4) of the unit-norm crops of ``x`` to each stored view in
        ``views`` (default: all), minimised over shifts, and the heading error (rad) of the
        best shift: turning by it (positive = left) lines the image up with the view."""
        ref = self._views if views is None else self._views[np.atleast_1d(views)]
        cur = self._images(np.asarray(x)[None])
        best = np.full(len(ref), np.inf)
        shift = np.zeros(len(ref))
        for s in range(-self.max_shift, self.max_shift + 1, step):
            d = 2.0 - 2.0 * ref @ self._crops(cur, s)[0]
            better = d < best
            best[better], shift[better] = d[better], s
        # The scene of a view to the robot's left appears shifted left in the image (smaller
        # column), so the crop that matches starts left of centre: s < 0 means turn left.
        return best, -shift * self.radians_per_pixel

    def manifold_scores(self, x: np.ndarray) -> np.ndarray:
        """eq. 13's normalised F^j(k) over clusters, as probabilities (``predict_proba``)."""
        return self.map.clustering.predict_proba(np.asarray(x, np.float32)[None])[0]

    def signal(self, x: np.ndarray, view: int) -> float:
        """F^j(k) of eq. 13 toward stored view ``view`` in its cluster, divided by F at the
        view itself: 1 at the view, 0 where its cluster gives no signal."""
        return float(self.signals(x, [view])[0])

    def signals(self, x: np.ndarray, views) -> np.ndarray:
        """:meth:`signal` toward each of ``views``, the image's squared distances to a
        cluster's points (the costly part: a projection of the whole image) computed once per
        cluster rather than once per view. Same numbers as ``clustering.signal``."""
        views = [int(v) for v in np.atleast_1d(views)]
        clustering = self.map.clustering
        for view in views:
            if view not in self._f_cache:
                own = clustering.signals(self.map.features[view], [view])[0, 0]
                self._f_cache[view] = max(float(own), 1e-12)
        f = clustering.signals(np.asarray(x, np.float32), views)[0]
        return f / np.array([self._f_cache[v] for v in views])

    def localise(self, x: np.ndarray, top: int = 2) -> tuple[int, float, float]:
        """Global fix from one image: among the views of the ``top`` clusters by eq. 13, the
        best-aligned one. Returns (view, heading error to it in rad, its aligned distance)."""
        proba = self.manifold_scores(x)
        clusters = np.argsort(proba)[::-1][: max(1, int(top))]
        views = np.flatnonzero(np.isin(self.map.clusters, clusters))
        d, yaw = self.align(x, views)
        k = int(np.argmin(d))
        return int(views[k]), float(yaw[k]), float(d[k])

    def parallax(self, min_offset: float = 0.15, trust: float = 0.9) -> float:
        """rad of best shift per m of offset across a view's line of sight, from the map's own
        views: for every view-graph edge whose sensed transform puts one view ``min_offset``
        m or more beside the other (nearly parallel, within 1 m along), the aligned shift
        minus the transform's heading change, regressed on the offset (least squares through
        0). The shift is z = theta + c y (a robot left of a view sees the scene shifted the
        way a right turn would): c ~ 1 / the scene's depth, about 0.15 in the hallway and 0.05
        on the lawn. Needs no ground truth (edges are scan-matched); 0 if no edge qualifies."""
        ys, zs = [], []
        for (i, j), t in zip(self.map.edges, self.map.edge_transforms, strict=True):
            for a, b, rel in ((i, j, t), (j, i, se2_relative(t, np.zeros(3)))):
                if abs(rel[1]) < min_offset or abs(rel[0]) > 1.0 or abs(rel[2]) > 0.3:
                    continue
                d, yaw = self.align(self.map.features[b], [a])
                if d[0] <= trust:
                    ys.append(rel[1])
                    zs.append(-yaw[0] - rel[2])
        if not ys:
            return 0.0
        y = np.asarray(ys)
        return float(max(y @ np.asarray(zs) / (y @ y), 0.0))
