"""The servo map of one world: stored views, their manifold clustering and the view graph.

The paper's robot servos between *stored views* (Section II-G): the training images of
``ManifoldClustering``. The map keeps, per stored view, its image, its feature vector, its laser
scan and its (ICP-refined) odometry pose, plus

* the clustering fitted on the views' image features (clusters = the map's manifolds; the
  servo signal F^j(k) of eq. 13 is computed with it),
* the *view graph*: consecutive views of a recorded sequence are joined by their scan-matched
  odometry increment, and views of different sequences that see the same place (nearest image
  feature, verified by ICP of their scans) by the ICP transform. Paths in it are the routes,
* the *manifold graph*: which cluster follows which in the recorded sequences.

The true poses and manifold labels of the views are kept too, for the env and the evaluation
only; the controller never reads them.

The map is built once per (dataset, settings) and cached as ``.npz`` + ``.json`` (no pickle),
keyed by a hash of the dataset's checksums, the settings and the clustering's source code.
"""

from __future__ import annotations

import hashlib
import json
import os
from dataclasses import asdict, dataclass, field
from pathlib import Path

import numpy as np

from mapping.features import ImageFeatures, scan_to_points
from mapping.icp import densify_scan, icp, refine_poses
from mapping.manifold import ManifoldClustering
from mapping.topology import se2_relative
from scenes import MANIFOLDS, WORLDS
from servo import estimator_io
from sim.dataset import Dataset, load_dataset, read_meta, write_sequence

FORMAT_VERSION = 1
DEFAULT_DATASET = Path("out/dataset")
DEFAULT_CACHE = Path("out/servo-maps")
_CLUSTERING_SOURCES = ("manifold.py", "_manifold_kernel.py", "_manifold_predict.py",
                       "_manifold_split.py", "_manifold_tree.py")  # fmt: skip


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
    link_radius : m, odometry distance within which views of two sequences may be linked.
    link_rmse : m, largest ICP residual accepted for a link.
    """

    stride: int = 2
    image_size: tuple[int, int] = (80, 60)
    min_cluster_size: int = 8
    link_radius: float = 4.0
    link_rmse: float = 0.06

    def __post_init__(self):
        if int(self.stride) != self.stride or self.stride < 1:
            raise ValueError(f"stride must be an integer >= 1, got {self.stride}")
        if int(self.min_cluster_size) != self.min_cluster_size or self.min_cluster_size < 1:
            raise ValueError(
                f"min_cluster_size must be an integer >= 1, got {self.min_cluster_size}"
            )

    def to_json(self) -> dict:
        d = asdict(self)
        d["image_size"] = list(self.image_size)
        return d


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


# -- building ---------------------------------------------------------------------------------
def _world_sequences(dataset: Dataset, world: str) -> list[str]:
    names = [n for n, s in dataset.sequences.items() if s.world == world]
    if not names:
        raise MapError(f"the dataset at {dataset.path} has no sequence of world {world!r}")
    return names


def map_key(meta: dict, world: str, settings: MapSettings) -> str:
    """Hash of what the map depends on: the world's sequence checksums, the settings, the
    feature and sensor settings of the dataset and the clustering's source code."""
    h = hashlib.sha256()
    entries = {n: e["sha256"] for n, e in meta["sequences"].items() if e["world"] == world}
    if not entries:
        raise MapError(f"the dataset has no sequence of world {world!r}")
    h.update(json.dumps([FORMAT_VERSION, world, entries, settings.to_json()]).encode())
    src = Path(ManifoldClustering.__module__.replace(".", "/")).parent
    root = Path(__file__).resolve().parents[1] / src
    for name in _CLUSTERING_SOURCES:
        p = root / name
        if p.is_file():
            h.update(p.read_bytes())
    return h.hexdigest()[:16]


def _link_sequences(
    feats: np.ndarray, poses: np.ndarray, seq: np.ndarray, points: list, dense: list, s: MapSettings
) -> tuple[list, list]:
    """Edges between views of different sequences that see the same place: the nearest view of
    the other sequence in image features (within ``link_radius`` by odometry), kept when ICP
    of the two scans converges with a small residual. One link per metre is plenty."""
    edges, transforms = [], []
    seqs = np.unique(seq)
    for a in seqs:
        for b in seqs[seqs > a]:
            ia, ib = np.flatnonzero(seq == a), np.flatnonzero(seq == b)
            for i in ia:
                near = ib[np.hypot(*(poses[ib, :2] - poses[i, :2]).T) < s.link_radius]
                if len(near) == 0:
                    continue
                d = np.sum((feats[near] - feats[i]) ** 2, axis=1)
                j = int(near[np.argmin(d)])
                res = icp(points[j], dense[i], init=se2_relative(poses[i], poses[j]))
                if (
                    res.converged
                    and res.rmse < s.link_rmse
                    and res.n_matches >= 0.7 * len(points[j])
                ):
                    edges.append((int(i), j))
                    transforms.append(res.transform)
    return edges, transforms


def build_map(
    dataset: Dataset | str | os.PathLike, world: str, settings: MapSettings | None = None
) -> ServoMap:
    """Fit the servo map of ``world`` from a dataset (see the module docstring)."""
    if world not in WORLDS:
        raise ValueError(f"world must be one of {WORLDS}, got {world!r}")
    settings = settings or MapSettings()
    if not isinstance(dataset, Dataset):
        dataset = load_dataset(dataset)
    names = _world_sequences(dataset, world)
    first = dataset.sequences[names[0]]
    max_range = float(dataset.meta["settings"]["laser"]["max_range"])
    cols: dict[str, list] = {k: [] for k in ("images", "scans", "poses", "true", "labels")}
    seq_ids, frames = [], []
    for k, name in enumerate(names):
        s = dataset.sequences[name]
        keep = np.arange(0, len(s), settings.stride)
        pts = [scan_to_points(r, s.angles, max_range) for r in s.scans]
        # Scan-matched odometry: the increments between stored views are what the controller
        # chains along a route, so make them as good as the recording allows.
        refined = refine_poses(pts, s.odometry)
        cols["images"].append(s.images[keep])
        cols["scans"].append(s.scans[keep])
        cols["poses"].append(refined[keep])
        cols["true"].append(s.poses[keep])
        cols["labels"].append(s.labels[keep])
        seq_ids.append(np.full(len(keep), k))
        frames.append(keep)
    images = np.concatenate(cols["images"])
    scans = np.concatenate(cols["scans"])
    poses = np.concatenate(cols["poses"])
    seq = np.concatenate(seq_ids)
    true_labels = np.concatenate(cols["labels"]).astype(np.int16)
    n_manifolds = len(np.unique(true_labels[true_labels >= 0]))

    image_features = ImageFeatures(size=tuple(settings.image_size), normalization="unit")
    feats = image_features.fit_transform(images).astype(np.float32)
    clustering = ManifoldClustering(
        n_clusters=max(2, n_manifolds), min_cluster_size=settings.min_cluster_size
    ).fit(feats)

    points = [scan_to_points(r, first.angles, max_range) for r in scans]
    dense = [densify_scan(p) for p in points]
    edges, transforms = [], []
    for i in range(len(seq) - 1):
        if seq[i] == seq[i + 1]:
            edges.append((i, i + 1))
            transforms.append(se2_relative(poses[i], poses[i + 1]))
    links, link_t = _link_sequences(feats, poses, seq, points, dense, settings)
    return ServoMap(
        world=world,
        key=map_key(dataset.meta, world, settings),
        images=images,
        features=feats,
        scans=scans,
        angles=first.angles.astype(np.float32),
        max_range=max_range,
        poses=poses,
        sequence=seq,
        frame=np.concatenate(frames),
        sequence_names=names,
        clusters=np.asarray(clustering.labels_, np.int64),
        edges=np.array(edges + links, np.int64).reshape(-1, 2),
        edge_transforms=np.array(transforms + link_t, np.float64).reshape(-1, 3),
        clustering=clustering,
        image_features=image_features,
        true_poses=np.concatenate(cols["true"]),
        true_labels=true_labels,
        settings=settings,
    )


# -- saving and loading -----------------------------------------------------------------------
_ARRAYS = ("images", "features", "scans", "angles", "poses", "sequence", "frame", "clusters",
           "edges", "edge_transforms", "true_poses", "true_labels")  # fmt: skip


def save_map(m: ServoMap, directory: str | os.PathLike) -> Path:
    """Write ``<world>-<key>.npz`` and ``.json`` atomically; returns the ``.json`` path."""
    directory = Path(directory)
    directory.mkdir(parents=True, exist_ok=True)
    stem = directory / f"{m.world}-{m.key}"
    arrays = {k: getattr(m, k) for k in _ARRAYS}
    c_meta, c_arrays = estimator_io.dump(m.clustering, "clustering")
    f_meta, f_arrays = estimator_io.dump(m.image_features, "image_features")
    digest = write_sequence(stem.with_suffix(".npz"), {**arrays, **c_arrays, **f_arrays})
    meta = {
        "format": "topomap-servo-map",
        "version": FORMAT_VERSION,
        "world": m.world,
        "key": m.key,
        "max_range": m.max_range,
        "sequence_names": m.sequence_names,
        "settings": m.settings.to_json(),
        "clustering": c_meta,
        "image_features": f_meta,
        "sha256": digest,
    }
    from scenes.fileio import atomic_write_bytes

    path = stem.with_suffix(".json")
    atomic_write_bytes(path, (json.dumps(meta, indent=2) + "\n").encode())
    return path


def load_map(path: str | os.PathLike) -> ServoMap:
    """Read a map written by :func:`save_map` (``allow_pickle=False``)."""
    path = Path(path).with_suffix(".json")
    if not path.is_file():
        raise MapError(f"no servo map at {path}")
    meta = json.loads(path.read_text())
    if meta.get("format") != "topomap-servo-map" or meta.get("version") != FORMAT_VERSION:
        raise MapError(f"{path} is not a servo map of format version {FORMAT_VERSION}")
    with np.load(path.with_suffix(".npz"), allow_pickle=False) as npz:
        arrays = {k: npz[k] for k in npz.files}
    s = meta["settings"]
    return ServoMap(
        world=meta["world"],
        key=meta["key"],
        max_range=float(meta["max_range"]),
        sequence_names=list(meta["sequence_names"]),
        clustering=estimator_io.load(ManifoldClustering, meta["clustering"], arrays, "clustering"),
        image_features=estimator_io.load(
            ImageFeatures, meta["image_features"], arrays, "image_features"
        ),
        settings=MapSettings(**{**s, "image_size": tuple(s["image_size"])}),
        **{k: arrays[k] for k in _ARRAYS},
    )


def load_or_build(
    world: str,
    dataset: str | os.PathLike = DEFAULT_DATASET,
    cache: str | os.PathLike = DEFAULT_CACHE,
    settings: MapSettings | None = None,
) -> ServoMap:
    """The cached map of ``world`` for this dataset and settings, built on first use."""
    settings = settings or MapSettings()
    path = Path(cache) / f"{world}-{map_key(read_meta(dataset), world, settings)}.json"
    if path.is_file():
        return load_map(path)
    m = build_map(load_dataset(dataset), world, settings)
    save_map(m, cache)
    return m
