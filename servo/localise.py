"""Camera-only localisation against a servo map's stored views.

``ImageLocaliser`` compares the current image with stored views in the map's feature space
(``ImageFeatures``: a small unit-normalised image), each comparison minimised over horizontal
shifts: a heading offset moves the scene sideways in the image, so the best shift is the
heading error toward that view (view-sequence navigation's image alignment), and the
residual says how alike the places are. The clustering's eq. 13 (``predict`` / F^j(k)) names
the manifold, and `ImageLocaliser.signal` is F toward one stored view.
"""

from __future__ import annotations

import numpy as np

from common.geometry import se2_relative
from servo.maps import ServoMap

MAX_SHIFT = 20  # feature-image pixels tried either way (80 px across the 58 deg camera)
HFOV = 2.0 * np.arctan(np.tan(np.deg2rad(45.0) / 2) * 4.0 / 3.0)  # rad, 320x240 at fovy 45


def check_observation(observation, keys: tuple[str, ...]) -> None:
    """Check a controller's observation: a dict holding ``keys``; else a ValueError saying which.

    Parameters
    ----------
    observation : dict
        The observation.
    keys : tuple of str
        The keys it must hold.
    """
    if not isinstance(observation, dict):
        raise ValueError(f"observation must be a dict, got {type(observation).__name__}")
    for key in keys:
        if key not in observation:
            raise ValueError(f"observation is missing {key!r}")


def check_odometry(odometry) -> np.ndarray:
    """Return ``observation['odometry']`` as a finite float (x, y, yaw); else a ValueError.

    Parameters
    ----------
    odometry : array_like of shape (3,)
        The odometry pose.

    Returns
    -------
    ndarray of shape (3,), float64
        The pose.
    """
    odo = np.asarray(odometry, np.float64)
    if odo.shape != (3,) or not np.all(np.isfinite(odo)):
        raise ValueError(
            f"observation['odometry'] must be a finite (x, y, yaw), got shape {odo.shape}"
        )
    return odo


def check_image(image, shape: tuple[int, ...], name: str = "observation['image']") -> np.ndarray:
    """Return ``image`` as an array of ``shape`` holding pixel values.

    Pixel values are a real numeric dtype (the env gives uint8; a float copy of it works as
    well) and finite values in [0, 255]. Anything else raises (TypeError for the dtype,
    ValueError for the shape or values), naming ``name``: a controller would otherwise act on
    it as on a real image.

    Parameters
    ----------
    image : array_like
        The image.
    shape : tuple of int
        The shape it must have.
    name : str, default "observation['image']"
        What errors call it.

    Returns
    -------
    ndarray
        The image, its dtype kept.
    """
    image = np.asarray(image)
    if image.dtype.kind not in "uif":  # not bool, complex, str or object
        raise TypeError(f"{name} must hold real numbers (uint8 pixels), got dtype {image.dtype}")
    if image.shape != tuple(shape):
        raise ValueError(f"{name} must have shape {tuple(shape)}, got {image.shape}")
    if image.dtype != np.uint8:  # uint8 is in range by its type: no pass over the pixels
        if not np.all(np.isfinite(image)):
            raise ValueError(f"{name} must be finite (no NaN or inf)")
        if image.size and (image.min() < 0 or image.max() > 255):
            raise ValueError(
                f"{name} must hold pixel values in [0, 255], got values in "
                f"[{image.min()}, {image.max()}]"
            )
    return image


class ImageLocaliser:
    """Shift-aligned image distances and F^j(k) toward stored views (see the module doc).

    Parameters
    ----------
    servo_map : ServoMap
        The map whose stored views are compared with.
    max_shift : int, default MAX_SHIFT
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
        images = self._images(servo_map.features)
        self._views = self._crops(images, 0)
        bands = self._band_rows().items()
        self._bands = {band: self._crops(images[:, rows], 0) for band, rows in bands}
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

    def _band_rows(self) -> dict[str, slice]:
        """Return the rows of the two bands `cross_offset` aligns.

        The bands are the top half (sky, trees, far walls: far, little parallax) and the bottom
        third (the ground and the bases of walls near the robot: near, much parallax).
        """
        h = self._wh[1]
        return {"far": slice(0, h // 2), "near": slice(2 * h // 3, h)}

    def _shifted_crops(self, band: np.ndarray) -> np.ndarray:
        """Return `_crops` of one image's ``band`` at every shift, (2 max_shift + 1, D).

        ``band`` is (rows, w, channels); the shifts run from -max_shift to max_shift, built at
        once from a sliding window.
        """
        s = self.max_shift
        w = band.shape[1] - 2 * s
        windows = np.lib.stride_tricks.sliding_window_view(band, w, axis=1)  # (r, 2s+1, c, w)
        c = windows.transpose(1, 0, 3, 2).reshape(2 * s + 1, -1)
        c = c - c.mean(axis=1, keepdims=True)
        return c / np.maximum(np.linalg.norm(c, axis=1, keepdims=True), 1e-12)

    def band_shifts(self, x: np.ndarray, views) -> tuple[np.ndarray, np.ndarray]:
        """Return the best horizontal shift of each band of ``x`` and its squared distance.

        The shift is in feature-image pixels (crop offset, as `align` before its sign and
        scale), the squared distance (0..4) that of the far and the near band of ``x`` against
        each stored view in ``views``.

        Parameters
        ----------
        x : ndarray of shape (d,)
            The image's feature vector.
        views : int or array_like of int
            Stored-view indices.

        Returns
        -------
        shifts : ndarray of shape (len(views), 2)
            The best shifts, columns far, near.
        dists : ndarray of shape (len(views), 2)
            Their squared distances, columns far, near.
        """
        views = np.atleast_1d(np.asarray(views, np.intp))
        cur = self._images(np.asarray(x)[None])[0]
        shifts = np.zeros((len(views), 2))
        dists = np.zeros((len(views), 2))
        for col, (band, rows) in enumerate(self._band_rows().items()):
            d = 2.0 - 2.0 * self._bands[band][views] @ self._shifted_crops(cur[rows]).T
            k = np.argmin(d, axis=1)  # the first of equal minima: the most negative shift
            shifts[:, col] = k - self.max_shift
            dists[:, col] = d[np.arange(len(views)), k]
        return shifts, dists

    # -- API --------------------------------------------------------------------------------
    def features(self, image, name: str = "observation['image']") -> np.ndarray:
        """Return the image's feature vector (d,); refuse what `check_image` refuses.

        Parameters
        ----------
        image : array_like of shape (H, W, 3)
            The camera image.
        name : str, default "observation['image']"
            What errors call it.

        Returns
        -------
        ndarray of shape (d,), float32
            The feature vector.
        """
        image = check_image(image, self.map.image_shape, name)
        return self.map.image_features.transform(image[None]).astype(np.float32)[0]

    def align(self, x: np.ndarray, views=None, step: int = 2) -> tuple[np.ndarray, np.ndarray]:
        """Return the shift-minimised squared distance of ``x`` to views, and the heading error.

        The squared distance (0..4) is that of the unit-norm crops of ``x`` to each stored
        view in ``views``, minimised over shifts; the heading error (rad) is that of the best
        shift: turning by it (positive = left) lines the image up with the view.

        Parameters
        ----------
        x : ndarray of shape (d,)
            The image's feature vector.
        views : int or array_like of int, optional
            Stored-view indices; default: all.
        step : int, default 2
            Pixels between the shifts tried.

        Returns
        -------
        distance : ndarray of shape (len(views),)
            The best squared distances.
        heading_error : ndarray of shape (len(views),)
            The heading errors, rad.
        """
        best, yaw, _ = self.align_contrast(x, views, step)
        return best, yaw

    def align_contrast(
        self, x: np.ndarray, views=None, step: int = 2
    ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Return `align`'s results and each view's best distance over its median over shifts.

        A real match is a sharp minimum (measured on the lawn: <= 0.21 at the view and up to
        1 m or 0.3 rad from it); grass and sky match a view turned 0.7 rad away almost as well
        at every shift (0.68-0.87), so that best shift says nothing of the heading.

        Parameters
        ----------
        x : ndarray of shape (d,)
            The image's feature vector.
        views : int or array_like of int, optional
            Stored-view indices; default: all.
        step : int, default 2
            Pixels between the shifts tried.

        Returns
        -------
        distance : ndarray of shape (len(views),)
            The best squared distances.
        heading_error : ndarray of shape (len(views),)
            The heading errors, rad.
        contrast : ndarray of shape (len(views),)
            The best distance over the median distance.
        """
        ref = self._views if views is None else self._views[np.atleast_1d(views)]
        cur = self._images(np.asarray(x)[None])
        shifts = np.arange(-self.max_shift, self.max_shift + 1, step)
        d = np.stack([2.0 - 2.0 * ref @ self._crops(cur, s)[0] for s in shifts], axis=1)
        k = np.argmin(d, axis=1)  # the first of equal minima, as a running strict minimum
        best = d[np.arange(len(ref)), k]
        contrast = best / np.maximum(np.median(d, axis=1), 1e-12)
        shift = shifts[k]
        # The scene of a view to the robot's left appears shifted left in the image (smaller
        # column), so the crop that matches starts left of centre: s < 0 means turn left.
        return best, -shift * self.radians_per_pixel, contrast

    def manifold_scores(self, x: np.ndarray) -> np.ndarray:
        """Return eq. 13's normalised F^j(k) over clusters, as probabilities (``predict_proba``).

        Parameters
        ----------
        x : ndarray of shape (d,)
            The image's feature vector.

        Returns
        -------
        ndarray of shape (n_clusters,)
            The probabilities.
        """
        return self.map.clustering.predict_proba(np.asarray(x, np.float32)[None])[0]

    def signal(self, x: np.ndarray, view: int) -> float:
        """Return F^j(k) of eq. 13 toward stored view ``view``, relative to F at the view.

        F is taken in the view's cluster and divided by F at the view itself: 1 at the view, 0
        where its cluster gives no signal.

        Parameters
        ----------
        x : ndarray of shape (d,)
            The image's feature vector.
        view : int
            The stored view's index.

        Returns
        -------
        float
            The relative F.
        """
        return float(self.signals(x, [view])[0])

    def signals(self, x: np.ndarray, views) -> np.ndarray:
        """Return `signal` toward each of ``views``.

        The image's squared distances to a cluster's points (the costly part: a projection of
        the whole image) are computed once per cluster rather than once per view. Same numbers
        as ``clustering.signal``.

        Parameters
        ----------
        x : ndarray of shape (d,)
            The image's feature vector.
        views : int or array_like of int
            Stored-view indices.

        Returns
        -------
        ndarray of shape (len(views),)
            The relative F toward each view.
        """
        views = [int(v) for v in np.atleast_1d(views)]
        clustering = self.map.clustering
        for view in views:
            if view not in self._f_cache:
                own = clustering.signals(self.map.features[view], [view])[0, 0]
                self._f_cache[view] = max(float(own), 1e-12)
        f = clustering.signals(np.asarray(x, np.float32), views)[0]
        return f / np.array([self._f_cache[v] for v in views])

    def localise(self, x: np.ndarray, top: int = 2) -> tuple[int, float, float]:
        """Localise one image globally: the best-aligned view of the ``top`` clusters by eq. 13.

        Parameters
        ----------
        x : ndarray of shape (d,)
            The image's feature vector.
        top : int, default 2
            The number of most probable clusters whose views are aligned.

        Returns
        -------
        view : int
            The best-aligned stored view.
        heading_error : float
            The heading error to it, rad.
        distance : float
            Its aligned squared distance.
        """
        proba = self.manifold_scores(x)
        clusters = np.argsort(proba)[::-1][: max(1, int(top))]
        views = np.flatnonzero(np.isin(self.map.clusters, clusters))
        d, yaw = self.align(x, views)
        k = int(np.argmin(d))
        return int(views[k]), float(yaw[k]), float(d[k])

    def _side_by_side(self, min_offset: float):
        """Yield (a, b, pose of view b in view a's frame) for side-by-side view pairs.

        A pair is each direction of every view-graph edge whose sensed transform puts one view
        ``min_offset`` m or more beside the other, nearly parallel (within 0.3 rad) and within
        1 m along: the map's own evidence of what an offset across a view's sight does to the
        image.
        """
        for (i, j), t in zip(self.map.edges, self.map.edge_transforms, strict=True):
            for a, b, rel in ((i, j, t), (j, i, se2_relative(t, np.zeros(3)))):
                if abs(rel[1]) >= min_offset and abs(rel[0]) <= 1.0 and abs(rel[2]) <= 0.3:
                    yield a, b, rel

    def cross_parallax(
        self, min_offset: float = 0.15, trust: float = 0.5, min_edges: int = 10
    ) -> float:
        """Estimate the near-band minus far-band shift per m of offset across a view's sight.

        The shift is in pixels (`band_shifts`), estimated from the map's own views as
        `parallax` (the view-graph edges with one view ``min_offset`` m or more beside the
        other; both bands within ``trust``, the near one not at the largest shift), least
        squares through 0. A turn moves both bands alike; an offset moves the near ground far
        more than the far scene, so the difference is the offset alone.

        Parameters
        ----------
        min_offset : float, default 0.15
            Metres one view of an edge must lie beside the other.
        trust : float, default 0.5
            The largest band distance used.
        min_edges : int, default 10
            The fewest edges an estimate is made from.

        Returns
        -------
        float
            Pixels per m; 0 where fewer than ``min_edges`` edges qualify or the slope is not
            positive (then `cross_offset` is never used).
        """
        ys, ds = [], []
        for a, b, rel in self._side_by_side(min_offset):
            shift, dist = self.band_shifts(self.map.features[b], [a])
            if dist.max() < trust and abs(shift[0, 1]) < self.max_shift:
                ys.append(rel[1])
                ds.append(shift[0, 1] - shift[0, 0])
        if len(ys) < min_edges:
            return 0.0
        y = np.asarray(ys)
        return float(max(y @ np.asarray(ds) / (y @ y), 0.0))

    def cross_offset(
        self, x: np.ndarray, view: int, pixels_per_m: float, trust: float = 0.5
    ) -> float:
        """Return the robot's offset across stored view ``view``'s line of sight.

        The offset (m, left positive) comes from the two bands' shifts, independent of the
        heading: (near - far) / ``pixels_per_m`` (`cross_parallax`).

        Parameters
        ----------
        x : ndarray of shape (d,)
            The image's feature vector.
        view : int
            The stored view's index.
        pixels_per_m : float
            `cross_parallax`'s estimate.
        trust : float, default 0.5
            The largest band distance used.

        Returns
        -------
        float
            The offset, m; NaN where either band matches worse than ``trust``, the near band's
            shift is at the largest tried (the offset is beyond what it measures), or
            ``pixels_per_m`` is not positive.
        """
        if not pixels_per_m > 0:
            return float("nan")
        shift, dist = self.band_shifts(x, [view])
        if dist.max() >= trust or abs(shift[0, 1]) >= self.max_shift:
            return float("nan")
        return float((shift[0, 1] - shift[0, 0]) / pixels_per_m)

    def parallax(self, min_offset: float = 0.15, trust: float = 0.9) -> float:
        """Estimate the rad of best shift per m of offset across a view's line of sight.

        The estimate comes from the map's own views: for every view-graph edge whose sensed
        transform puts one view ``min_offset`` m or more beside the other (nearly parallel,
        within 1 m along), the aligned shift minus the transform's heading change, regressed on
        the offset (least squares through 0). The shift is z = theta + c y (a robot left of a
        view sees the scene shifted the way a right turn would): c ~ 1 / the scene's depth,
        about 0.15 in the hallway and 0.05 on the lawn. Needs no ground truth (edges are
        scan-matched).

        Parameters
        ----------
        min_offset : float, default 0.15
            Metres one view of an edge must lie beside the other.
        trust : float, default 0.9
            The largest aligned distance used.

        Returns
        -------
        float
            Rad per m (not negative); 0 if no edge qualifies.
        """
        ys, zs = [], []
        for a, b, rel in self._side_by_side(min_offset):
            d, yaw = self.align(self.map.features[b], [a])
            if d[0] <= trust:
                ys.append(rel[1])
                zs.append(-yaw[0] - rel[2])
        if not ys:
            return 0.0
        y = np.asarray(ys)
        return float(max(y @ np.asarray(zs) / (y @ y), 0.0))
