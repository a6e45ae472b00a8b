"""The servo map's data: :class:`ServoMap` (stored views and the graphs over them), the
:class:`MapSettings` that determine it besides the dataset, and :class:`MapError`.

Building lives in ``servo.maps.build``, the file format in ``servo.maps.file``.
"""

from __future__ import annotations

import dataclasses
from dataclasses import asdict, dataclass, field

import numpy as np

from common.geometry import scan_to_points
from common.validation import check_int
from mapping.features import ImageFeatures
from mapping.manifold import ManifoldClustering
from scenes import MANIFOLDS


class MapError(ValueError):
    """A servo map that does not fit the world, the sensors or the request."""


@dataclass(frozen=True)
class MapSettings:
    """What determines a map besides the dataset.

    stride : keep every ``stride``-th frame of each sequence as a stored view (2: the paper's
        split, frames 0, 2, 4, ... build the map).
    image_size : (width, height) of the image features (``ImageFeatures``, unit-normalised so
        brightness changes cancel).
    min_cluster_size : Q of ``ManifoldClustering``.
    link_radius : m, distance (the two sequences aligned by sensing) within which views of two
        sequences may be linked.
    link_rmse : m, largest ICP residual accepted for a link.
    """

    stride: int = 2
    image_size: tuple[int, int] = (80, 60)
    min_cluster_size: int = 8
    link_radius: float = 4.0
    link_rmse: float = 0.06

    def __post_init__(self):
        check_int(self.stride, "stride")
        check_int(self.min_cluster_size, "min_cluster_size")

    def to_json(self) -> dict:
        d = asdict(self)
        d["image_size"] = list(self.image_size)
        return d

    @classmethod
    def from_json(cls, d) -> MapSettings:
        """The inverse of :meth:`to_json`, for untrusted input: exactly these keys, each of
        the declared type; raises ``ValueError`` naming the field."""
        fields = {f.name for f in dataclasses.fields(cls)}
        if not isinstance(d, dict) or set(d) != fields:
            raise ValueError(f"settings must have exactly the keys {sorted(fields)}")
        size = d["image_size"]
        if not (isinstance(size, list) and len(size) == 2
                and all(isinstance(v, int) and v > 0 for v in size)):  # fmt: skip
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
    """The stored views of one world and the graphs over them (see the module docstring).

    Arrays are indexed by view: ``images`` (n, H, W, 3) uint8, ``features`` (n, d) float32,
    ``scans`` (n, B) float32, ``poses`` (n, 3) refined odometry in each sequence's own frame,
    ``sequence`` (n,) and ``frame`` (n,) where it was recorded, ``clusters`` (n,) the
    clustering's labels. ``edges`` (E, 2) with ``edge_transforms`` (E, 3): the pose of view
    ``edges[e, 1]`` in the frame of view ``edges[e, 0]`` (one direction stored).
    ``true_poses`` and ``true_labels`` are ground truth for the env and evaluation only.
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

    def __len__(self) -> int:
        return len(self.clusters)

    @property
    def n_clusters(self) -> int:
        return int(self.clusters.max()) + 1

    @property
    def image_shape(self) -> tuple[int, ...]:
        return tuple(self.images.shape[1:])

    @property
    def manifold_graph(self) -> np.ndarray:
        """(K, K) bool: cluster b follows cluster a somewhere in a recorded sequence (both ways
        stored: a robot may drive a corridor either way)."""
        K = self.n_clusters
        adj = np.zeros((K, K), bool)
        for s in np.unique(self.sequence):
            c = self.clusters[self.sequence == s]
            change = c[1:] != c[:-1]
            adj[c[:-1][change], c[1:][change]] = True
        return adj | adj.T

    def true_manifold(self, view: int) -> str | None:
        label = int(self.true_labels[view])
        return None if label < 0 else MANIFOLDS[label]

    def check_view(self, view, name: str = "target") -> int:
        """``view`` as a valid stored-view index, or a ``MapError`` naming ``name``."""
        if isinstance(view, bool) or not isinstance(view, int | np.integer):
            raise MapError(f"{name} must be the integer index of a stored view, got {view!r}")
        if not 0 <= int(view) < len(self):
            raise MapError(
                f"{name} must be a stored view in [0, {len(self)}) of the {self.world} map, "
                f"got {view}"
            )
        return int(view)

    def check_world(self, world: str) -> None:
        if world != self.world:
            raise MapError(
                f"this servo map was fitted on the {self.world!r} world and cannot be used in "
                f"the {world!r} world: build the map from the {world!r} dataset"
            )

    def scan_points(self, view: int) -> np.ndarray:
        return scan_to_points(self.scans[view], self.angles, self.max_range)
