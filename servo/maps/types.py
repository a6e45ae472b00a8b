"""The servo map's data: the map, its settings and its error.

[`ServoMap`][servo.maps.types.ServoMap] (stored views and the graphs over them), the
[`MapSettings`][servo.maps.types.MapSettings] that determine it besides the dataset, and
[`MapError`][servo.maps.types.MapError].

Building lives in ``servo.maps.build``, the file format in ``servo.maps.file``.
"""

from __future__ import annotations

import dataclasses
import operator
from dataclasses import asdict, dataclass, field

import numpy as np

from common.geometry import scan_to_points
from common.validation import check_int
from mapping.features import ImageFeatures
from mapping.manifold import ManifoldClustering
from scenes.families import parse_world_name
from sim.collect_worlds import world_manifold_names


def prior_clusters(world: str) -> int:
    """Return the default K of a map of ``world``.

    K is the number of manifolds the world's plan was drawn with (``World.manifold_names``: a
    main corridor or lawn and its branches), a prior, not a count of labels; 2 for a place that
    is no world of this testbed.

    Parameters
    ----------
    world : str
        The world's name.

    Returns
    -------
    int
        The number of manifolds of ``world``, or 2.
    """
    try:
        parse_world_name(world)
    except ValueError:
        return 2  # a place that is no world of this testbed: the smallest split
    return len(world_manifold_names(world))


class MapError(ValueError):
    """A servo map that does not fit the world, the sensors or the request."""


@dataclass(frozen=True)
class MapSettings:
    """What determines a servo map besides the dataset.

    Parameters
    ----------
    stride : int, default 2
        Keep every ``stride``-th frame of each recording as a stored view (2: the paper's
        split, frames 0, 2, 4, ... build the map).
    image_size : (int, int), default (80, 60)
        (width, height) of the image features (``ImageFeatures``, unit-normalised so that
        brightness changes cancel).
    min_cluster_size : int, default 8
        Q of ``ManifoldClustering``.
    link_radius : float, default 4.0
        Distance within which views of two recordings (aligned by sensing) may be linked, m.
    link_rmse : float, default 0.06
        Largest ICP residual accepted for a link, m.
    n_clusters : int or None, default None
        K of ``ManifoldClustering``: the number of manifolds the map is split into, a stated
        prior. None: the world's prior, `prior_clusters` (a shipped world's main
        corridor or lawn and its three branches: 4; a generated world's manifold count), else
        2. Never read from the recordings' labels.

    Attributes
    ----------
    stride, image_size, min_cluster_size, link_radius, link_rmse, n_clusters
        The parameters (the object is frozen).

    Examples
    --------
    >>> from servo import MapSettings
    >>> settings = MapSettings(min_cluster_size=10)
    >>> settings.to_json()["image_size"]
    [80, 60]
    >>> MapSettings.from_json(settings.to_json()) == settings
    True

    See Also
    --------
    servo.maps.build_map : Builds a map with these settings.
    servo.maps.map_key : The cache key they enter.
    """

    stride: int = 2
    image_size: tuple[int, int] = (80, 60)
    min_cluster_size: int = 8
    link_radius: float = 4.0
    link_rmse: float = 0.06
    n_clusters: int | None = None

    def __post_init__(self):
        """Check that ``stride``, ``min_cluster_size`` are integers >= 1, ``n_clusters`` >= 2."""
        check_int(self.stride, "stride")
        check_int(self.min_cluster_size, "min_cluster_size")
        if self.n_clusters is not None:
            check_int(self.n_clusters, "n_clusters", minimum=2)

    def clusters_for(self, world: str) -> int:
        """Return K for a map of ``world``: ``n_clusters``, or the world's prior.

        Parameters
        ----------
        world : str
            The world the map is of.

        Returns
        -------
        int
            The number of clusters the map is split into.
        """
        if self.n_clusters is not None:
            return int(self.n_clusters)
        return prior_clusters(world)

    def to_json(self) -> dict:
        """Return the settings as the map's file stores them (``image_size`` as a list).

        Returns
        -------
        dict
            One entry per field.
        """
        d = asdict(self)
        d["image_size"] = list(self.image_size)
        return d

    @classmethod
    def from_json(cls, d) -> MapSettings:
        """Read settings back: the inverse of [`to_json`][servo.maps.types.MapSettings.to_json].

        For untrusted input: exactly these keys, each of the declared type (``n_clusters`` may be
        missing, as in a file written before it was a setting: None).

        Parameters
        ----------
        d : dict
            The settings as [`to_json`][servo.maps.types.MapSettings.to_json] gives them.

        Returns
        -------
        MapSettings
            The settings.

        Raises
        ------
        ValueError
            Naming the field, when a key is missing or extra or a value is not of its type.
        """
        fields = {f.name for f in dataclasses.fields(cls)}
        if isinstance(d, dict) and "n_clusters" not in d:
            d = {**d, "n_clusters": None}
        if not isinstance(d, dict) or set(d) != fields:
            raise ValueError(f"settings must have exactly the keys {sorted(fields)}")
        k = d["n_clusters"]
        if k is not None and (not isinstance(k, int) or isinstance(k, bool) or k < 2):
            raise ValueError(f"settings.n_clusters must be an integer >= 2 or null, got {k!r}")
        size = d["image_size"]
        if not (
            isinstance(size, list)
            and len(size) == 2
            and all(isinstance(v, int) and v > 0 for v in size)
        ):
            raise ValueError(f"settings.image_size must be two positive integers, got {size!r}")
        for name in ("stride", "min_cluster_size"):
            if not isinstance(d[name], int) or isinstance(d[name], bool):
                raise ValueError(f"settings.{name} must be an integer, got {d[name]!r}")
        for name in ("link_radius", "link_rmse"):
            v = d[name]
            if not isinstance(v, int | float) or isinstance(v, bool) or not v > 0:
                raise ValueError(f"settings.{name} must be a positive number, got {v!r}")
        return cls(**{**d, "image_size": tuple(size)})


@dataclass
class ServoMap:
    """The stored views of one world and the graphs over them.

    Built from a dataset by [`build_map`][servo.maps.build.build_map] (cached by
    [`load_or_build`][servo.maps.build.load_or_build]), saved and loaded by
    [`save_map`][servo.maps.file.save_map] and [`load_map`][servo.maps.file.load_map]. No ground
    truth goes into building it: each recording's odometry starts at its own origin and recordings
    are joined by scan and image matching only; ``true_poses`` and ``true_labels`` are kept for the
    env and the evaluation.

    Parameters
    ----------
    world : str
        The world the views were recorded in.
    key : str
        The cache key: the dataset's checksums, the settings and the code that built the map.
    images : ndarray of shape (n, H, W, 3), uint8
        The stored views' images.
    features : ndarray of shape (n, d), float32
        Their image features (``image_features.transform(images)``).
    scans : ndarray of shape (n, B), float32
        Their laser ranges (+inf: no return).
    angles : ndarray of shape (B,)
        The beams' angles, rad.
    max_range : float
        The laser's range, m.
    poses : ndarray of shape (n, 3)
        Odometry refined by scan matching, in each recording's own frame.
    sequence, frame : ndarray of shape (n,), int
        The recording and frame of each view.
    sequence_names : list of str
        The recordings' names.
    clusters : ndarray of shape (n,), int
        The manifold clustering's labels.
    edges : ndarray of shape (E, 2), int
        Pairs of linked views (one direction stored).
    edge_transforms : ndarray of shape (E, 3)
        The pose of view ``edges[e, 1]`` in the frame of view ``edges[e, 0]``.
    clustering : ManifoldClustering
        The fitted clustering of ``features``.
    image_features : ImageFeatures
        The fitted image transformer.
    true_poses : ndarray of shape (n, 3)
        The views' true poses (evaluation only).
    true_labels : ndarray of shape (n,), int
        The views' true manifolds, indices into ``manifold_names`` (evaluation only).
    settings : MapSettings, default MapSettings()
        The settings it was built with.
    world_digest : str, optional
        The SHA-256 of the world's floor plan (`scenes.World.digest`); None in the map
        a policy is given ([`servo.task.interface.sensed_map`][servo.task.interface.sensed_map]).
    manifold_names : tuple of str, default ()
        The names ``true_labels`` index: the dataset's manifolds (evaluation only; empty in
        the map a policy is given).

    Attributes
    ----------
    world, key, images, ..., settings
        The parameters, as given.
    n_clusters : int
        Number of clusters.
    image_shape : tuple of int
        (H, W, 3) of the stored images.
    manifold_graph : ndarray of shape (n_clusters, n_clusters), bool
        Cluster b follows cluster a somewhere in a recording (both ways stored).

    Examples
    --------
    >>> import sim  # headless rendering, chosen before anything imports mujoco
    >>> from servo import load_or_build
    >>> from sim.collect import CollectionSettings, collect_dataset
    >>> data = collect_dataset("lawn-40", CollectionSettings(worlds=("lawn",), frames=40),
    ...                        jobs=1, progress=False)  # three drives of 40 frames, ~10 s
    >>> servo_map = load_or_build("lawn", data, cache="servo-maps", progress=False)
    >>> len(servo_map), servo_map.world, servo_map.image_shape
    (60, 'lawn', (240, 320, 3))
    >>> servo_map.sequence_names
    ['lawn-left', 'lawn-straight', 'lawn-right']
    >>> servo_map.manifold_graph.shape == (servo_map.n_clusters,) * 2
    True

    See Also
    --------
    servo.maps.load_or_build : The cached map of a world, built on first use.
    servo.maps.MapSettings : What determines a map besides the dataset.
    servo.ServoEnv : The task on a map.
    """

    world: str
    key: str
    images: np.ndarray
    features: np.ndarray
    scans: np.ndarray
    angles: np.ndarray
    max_range: float
    poses: np.ndarray
    sequence: np.ndarray
    frame: np.ndarray
    sequence_names: list[str]
    clusters: np.ndarray
    edges: np.ndarray
    edge_transforms: np.ndarray
    clustering: ManifoldClustering
    image_features: ImageFeatures
    true_poses: np.ndarray
    true_labels: np.ndarray
    settings: MapSettings = field(default_factory=MapSettings)
    world_digest: str | None = None
    manifold_names: tuple[str, ...] = ()

    def __len__(self) -> int:
        """Return the number of stored views."""
        return len(self.clusters)

    @property
    def n_clusters(self) -> int:
        """Number of clusters of the stored views."""
        return int(self.clusters.max()) + 1

    @property
    def image_shape(self) -> tuple[int, ...]:
        """(H, W, 3) of the stored images."""
        return tuple(self.images.shape[1:])

    @property
    def manifold_graph(self) -> np.ndarray:
        """(K, K) bool: cluster b follows cluster a somewhere in a recorded sequence.

        Both ways are stored: a robot may drive a corridor either way.
        """
        K = self.n_clusters
        adj = np.zeros((K, K), bool)
        for s in np.unique(self.sequence):
            c = self.clusters[self.sequence == s]
            change = c[1:] != c[:-1]
            adj[c[:-1][change], c[1:][change]] = True
        return adj | adj.T

    def true_manifold(self, view: int) -> str | None:
        """Return the true manifold of stored view ``view``; for evaluation only.

        Parameters
        ----------
        view : int
            Index of a stored view.

        Returns
        -------
        str or None
            The manifold's name; None where the view is on none.
        """
        label = int(self.true_labels[view])
        return None if label < 0 else self.manifold_names[label]

    def check_view(self, view, name: str = "target") -> int:
        """Return ``view`` as a valid stored-view index, or raise a ``MapError`` naming ``name``.

        Parameters
        ----------
        view : int or object with ``__index__``
            An integer or an object that is one (``__index__``, as ``servo.task.Target``).
        name : str, default "target"
            What ``view`` is called in the error message.

        Returns
        -------
        int
            The index, in ``[0, len(self))``.

        Raises
        ------
        MapError
            When ``view`` is no integer or no stored view of this map.
        """
        if isinstance(view, bool | np.bool_) or not hasattr(type(view), "__index__"):
            raise MapError(f"{name} must be the integer index of a stored view, got {view!r}")
        view = operator.index(view)
        if not 0 <= int(view) < len(self):
            raise MapError(
                f"{name} must be a stored view in [0, {len(self)}) of the {self.world} map, "
                f"got {view}"
            )
        return int(view)

    def check_world(self, world: str, digest: str | None = None) -> None:
        """Raise ``MapError`` unless this map was built for ``world``.

        Where both are known, the map's floor plan must also be of this ``digest`` (else a
        generator changed).

        Parameters
        ----------
        world : str
            The world the map is to be used in.
        digest : str or None, default None
            The SHA-256 of that world's floor plan; None: not checked.

        Raises
        ------
        MapError
            When the map was built for another world or floor plan.
        """
        if world != self.world or (digest and self.world_digest and digest != self.world_digest):
            raise MapError(
                f"this servo map was fitted on the {self.world!r} world and cannot be used in "
                f"the {world!r} world: build the map from the {world!r} dataset"
            )

    def scan_points(self, view: int) -> np.ndarray:
        """Return the scan of stored view ``view`` as points in its frame, no-returns dropped.

        Parameters
        ----------
        view : int
            Index of a stored view.

        Returns
        -------
        ndarray of shape (M, 2)
            The scan's points, m.
        """
        return scan_to_points(self.scans[view], self.angles, self.max_range)
