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

The map is built once per (dataset, settings) and cached in the format of ``servo.map_file``
(no pickle, verified on load), keyed by a hash of the dataset's checksums, the settings, the
source of every module that builds or stores a map, and the numeric libraries' versions.
"""

from __future__ import annotations

import hashlib
import json
import os
import warnings
from importlib.metadata import PackageNotFoundError, version
from pathlib import Path

import numpy as np

import mapping
from common.geometry import scan_to_points, se2_relative
from mapping.features import ImageFeatures
from mapping.icp import densify_scan, icp
from mapping.manifold import ManifoldClustering
from mapping.scan_matching import refine_poses
from scenes import WORLDS
from servo.map_file import FORMAT_VERSION, load_map, map_paths, save_map
from servo.map_types import MapError, MapSettings, ServoMap
from sim import datahome
from sim.dataset import Dataset, load_dataset, read_meta

__all__ = ["MapError", "MapSettings", "ServoMap", "build_map", "load_map", "load_or_build",
           "map_key", "save_map"]  # fmt: skip

# Everything whose code decides a map's content or file: a change to any of them is a new key.
_KEY_PACKAGES = ("numpy", "scipy", "scikit-learn", "opencv-python-headless")


def _key_sources() -> list[Path]:
    servo_dir = Path(__file__).resolve().parent
    sim_dir = Path(datahome.__file__).resolve().parent
    return sorted(Path(mapping.__file__).resolve().parent.glob("*.py")) + [
        servo_dir / "map_store.py",
        servo_dir / "map_types.py",
        servo_dir / "map_file.py",
        sim_dir / "dataset.py",
    ]


def _versions() -> list[str]:
    out = []
    for name in _KEY_PACKAGES:
        try:
            out.append(f"{name}=={version(name)}")
        except PackageNotFoundError:
            out.append(f"{name} missing")
    return out


# -- building ---------------------------------------------------------------------------------
def _world_sequences(dataset: Dataset, world: str) -> list[str]:
    names = [n for n, s in dataset.sequences.items() if s.world == world]
    if not names:
        raise MapError(f"the dataset at {dataset.path} has no sequence of world {world!r}")
    return names


def map_key(meta: dict, world: str, settings: MapSettings) -> str:
    """Hash of what the map depends on: the world's sequence checksums, the settings, the
    source of every module that builds or stores a map (the whole ``mapping`` package, the
    servo map modules, the dataset reader) and the numeric libraries' versions."""
    h = hashlib.sha256()
    entries = {n: e["sha256"] for n, e in meta["sequences"].items() if e["world"] == world}
    if not entries:
        raise MapError(f"the dataset has no sequence of world {world!r}")
    h.update(json.dumps([FORMAT_VERSION, world, entries, settings.to_json(), _versions()]).encode())
    for p in _key_sources():
        h.update(p.name.encode() + b"\0" + p.read_bytes())
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


def load_or_build(
    world: str,
    dataset: str | os.PathLike | None = None,
    cache: str | os.PathLike | None = None,
    settings: MapSettings | None = None,
    *,
    home: str | os.PathLike | None = None,
    progress: bool = True,
) -> ServoMap:
    """The cached map of ``world`` for this dataset and settings, built on first use.

    ``dataset`` and ``cache`` default to the data home's (``sim.datahome``: the ``home``
    argument, then ``TOPOMAP_HOME``, then the per-user cache), never the working directory;
    the default dataset is collected there when missing. A cached map that fails
    :func:`~servo.map_file.load_map`'s checks is rebuilt, with a warning saying why.
    """
    if world not in WORLDS:
        raise ValueError(f"world must be one of {WORLDS}, got {world!r}")
    settings = settings or MapSettings()
    if dataset is None:
        dataset = datahome.default_dataset(home, progress=progress)
    dataset = Path(dataset)
    if dataset.exists() and not dataset.is_dir():
        raise ValueError(f"dataset must be a dataset folder, got the file {dataset}")
    cache = datahome.maps_dir(home) if cache is None else Path(cache)
    if cache.exists() and not cache.is_dir():
        raise ValueError(f"cache must be a folder for servo maps, got the file {cache}")
    path, _ = map_paths(cache, world, map_key(read_meta(dataset), world, settings))
    if path.is_file():
        try:
            return load_map(path, world)
        except MapError as err:
            warnings.warn(f"rebuilding the servo map: {err}", RuntimeWarning, stacklevel=2)
    m = build_map(load_dataset(dataset), world, settings)
    save_map(m, cache)
    return m
