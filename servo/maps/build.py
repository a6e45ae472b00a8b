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

The map is built once per (dataset, settings) and cached in the format of ``servo.maps.file``
(no pickle, verified on load), keyed by a hash of the dataset's checksums, the settings, the
source of every module that builds or stores a map, and the numeric libraries' versions.
"""

from __future__ import annotations

import hashlib
import json
import os
import sys
import warnings
from importlib.metadata import PackageNotFoundError, version
from pathlib import Path

import numpy as np
from scipy import ndimage

import mapping
from common.geometry import (
    scan_to_points,
    se2_compose,
    se2_inverse,
    se2_mean,
    se2_relative,
    thin_to_grid,
    transform_points,
    wrap_angle,
)
from mapping.features import ImageFeatures
from mapping.manifold import ManifoldClustering
from mapping.scan_matching import densify_scan, icp, refine_poses
from scenes.families import check_world_name
from servo.maps.file import FORMAT_VERSION, load_map, map_paths, save_map
from servo.maps.needs import check_needs
from servo.maps.scan_profile import clip_ranges, profile_distances
from servo.maps.types import MapError, MapSettings, ServoMap
from sim import datahome
from sim.collect_worlds import world_digest
from sim.dataset import Dataset, DatasetError, load_dataset, read_meta

__all__ = [
    "MapError",
    "MapSettings",
    "ServoMap",
    "build_map",
    "load_map",
    "load_or_build",
    "map_key",
    "save_map",
]

# Everything whose code decides a map's content or file: a change to any of them is a new key.
_KEY_PACKAGES = ("numpy", "scipy", "scikit-learn", "opencv-python-headless")
LINK_CANDIDATES = 3  # views of the other sequence, nearest in image features, tried by ICP
CONSENSUS = (0.5, 0.1)  # m, rad: verified pairs agreeing on two sequences' alignment
MIN_LINKS = 3  # agreeing links needed to join two sequences


def _key_sources() -> list[tuple[str, Path]]:
    """Return ``(name, path)`` of every source file whose code decides a map's content or file.

    These are the whole ``mapping`` package, this package and the dataset reader, each named by
    its path below the repository's root.
    """
    maps_dir = Path(__file__).resolve().parent
    mapping_dir = Path(mapping.__file__).resolve().parent
    root = mapping_dir.parent
    dataset_reader = Path(datahome.__file__).resolve().parent / "dataset"
    files = [*mapping_dir.rglob("*.py"), *maps_dir.glob("*.py"), *dataset_reader.glob("*.py")]
    return sorted((p.relative_to(root).as_posix(), p) for p in files)


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
    """Return the hash of what the map depends on.

    That is the world's sequence checksums, the settings (the clustering's K among them,
    [`MapSettings.clusters_for`][servo.maps.types.MapSettings.clusters_for]), the source of every
    module that builds or stores a map (the whole ``mapping`` package, the servo map modules, the
    dataset reader) and the numeric libraries' versions.

    Parameters
    ----------
    meta : dict
        The dataset's ``meta.json`` content (its ``"sequences"`` with their world and sha256).
    world : str
        The world's name (``"hallway"``, ``"lawn"`` or ``FAMILY:SEED``).
    settings : MapSettings
        The settings the map is built with.

    Returns
    -------
    str
        The first 16 hex digits of the SHA-256.

    Raises
    ------
    MapError
        When the dataset has no sequence of ``world``.
    """
    h = hashlib.sha256()
    world = check_world_name(world)
    entries = {n: e["sha256"] for n, e in meta["sequences"].items() if e["world"] == world}
    if not entries:
        raise MapError(f"the dataset has no sequence of world {world!r}")
    # the K the clustering is given (MapSettings.clusters_for), beside the settings that state it
    k = settings.clusters_for(world)
    settings_json = [settings.to_json(), k]
    # The world's floor plan too: a generated world whose generator changed is another world.
    head = [FORMAT_VERSION, world, world_digest(world), entries, settings_json, _versions()]
    h.update(json.dumps(head).encode())
    for name, p in _key_sources():
        h.update(name.encode() + b"\0" + p.read_bytes())
    return h.hexdigest()[:16]


def _verified(res, n_points: int, s: MapSettings) -> bool:
    """Check that an ICP of two views' scans says they see the same place."""
    return bool(res.converged and res.rmse < s.link_rmse and res.n_matches >= 0.7 * n_points)


def _sequence_alignment(
    feats: np.ndarray,
    poses: np.ndarray,
    ia: np.ndarray,
    ib: np.ndarray,
    ranges: np.ndarray,
    points: list,
    dense: list,
    beam_step: float,
    s: MapSettings,
) -> np.ndarray | None:
    """Return the rigid transform from sequence b's odometry frame to sequence a's.

    It comes from what the robot sensed only (each recording's odometry has its own origin):
    every view of a is paired with the ``LINK_CANDIDATES`` views of b nearest in image features,
    each pair
    verified by ICP of the scans (seeded with the heading of the best laser-profile shift).
    A verified pair implies a transform between the two frames; the answer is the mean of
    those agreeing with the one most others agree with (within ``CONSENSUS``), so a look-alike
    place elsewhere (a mirrored branch, a uniform stretch of corridor where ICP slides) is
    outvoted. None when fewer than ``MIN_LINKS`` agree: the sequences are not joined.
    """
    between = []
    for i in ia[::2]:  # plenty of pairs to vote
        d = np.sum((feats[ib] - feats[i]) ** 2, axis=1)
        near = ib[np.argsort(d)[:LINK_CANDIDATES]]
        _, yaw = profile_distances(ranges[near], ranges[i], beam_step)
        for j, heading in zip(near, yaw, strict=True):
            res = icp(points[j], dense[i], init=(0.0, 0.0, -heading))
            if _verified(res, len(points[j]), s):
                between.append(
                    se2_compose(se2_compose(poses[i], res.transform), se2_inverse(poses[j]))
                )
    if not between:
        return None
    between = np.array(between)
    dxy = np.hypot(*(between[:, None, :2] - between[None, :, :2]).transpose(2, 0, 1))
    dyaw = np.abs(wrap_angle(between[:, None, 2] - between[None, :, 2]))
    agree = (dxy < CONSENSUS[0]) & (dyaw < CONSENSUS[1])
    mode = int(np.argmax(agree.sum(axis=1)))
    if agree[mode].sum() < MIN_LINKS:
        return None
    # One pair of views can slide along a uniform corridor (its scans hold only the side
    # walls); the two recordings' whole clouds hold the junctions and the furniture that pin
    # it. ICP of the clouds still slides (its cost is flat along the corridor), so the most
    # overlapping offset is searched for on a grid around the consensus.
    cloud_a = _sequence_cloud(poses[ia], [dense[k] for k in ia])
    cloud_b = _sequence_cloud(poses[ib], [points[k] for k in ib])
    coarse = _overlap_search(cloud_a, cloud_b, se2_mean(between[agree[mode]]))
    return _overlap_search(
        cloud_a, cloud_b, coarse, reach=0.1, step=0.025, yaw_reach=0.02, yaw_step=0.01
    )


def _overlap_search(
    cloud_a: np.ndarray,
    cloud_b: np.ndarray,
    init: np.ndarray,
    reach: float = 1.0,
    step: float = 0.1,
    yaw_reach: float = 0.06,
    yaw_step: float = 0.02,
    tol: float = 0.05,
) -> np.ndarray:
    """Return the pose that puts the most of ``cloud_b`` within ``tol`` of ``cloud_a``.

    The pose is searched within ``reach`` m / ``yaw_reach`` rad of ``init``, on a grid (a
    distance-transform lookup).
    """
    res = tol / 2
    lo = cloud_a.min(axis=0) - 1.0
    cells = np.floor((cloud_a - lo) / res).astype(np.int64)
    shape = tuple(cells.max(axis=0)[::-1] + 2)
    occupied = np.zeros(shape, bool)
    occupied[cells[:, 1], cells[:, 0]] = True
    near = ndimage.distance_transform_edt(~occupied) * res <= tol
    b = cloud_b[:: max(1, len(cloud_b) // 1500)]
    offsets = np.arange(-reach, reach + step / 2, step)
    grid = np.stack(np.meshgrid(offsets, offsets, indexing="ij"), -1).reshape(-1, 2)
    best = (-1, init)
    for dyaw in np.arange(-yaw_reach, yaw_reach + yaw_step / 2, yaw_step):
        pose = np.array([init[0], init[1], init[2] + dyaw])
        moved = transform_points(pose, b)[None, :, :] + grid[:, None, :]
        j = np.floor((moved[..., 0] - lo[0]) / res).astype(np.int64)
        i = np.floor((moved[..., 1] - lo[1]) / res).astype(np.int64)
        inside = (i >= 0) & (i < shape[0]) & (j >= 0) & (j < shape[1])
        hit = np.zeros(i.shape, bool)
        hit[inside] = near[i[inside], j[inside]]
        score = hit.sum(axis=1)
        k = int(np.argmax(score))
        if score[k] > best[0]:
            best = (int(score[k]), np.array([pose[0] + grid[k, 0], pose[1] + grid[k, 1], pose[2]]))
    return best[1]


def _sequence_cloud(poses: np.ndarray, scans: list, spacing: float = 0.05) -> np.ndarray:
    """Return one recording's scans placed by its odometry and thinned to a ``spacing`` grid."""
    pts = np.concatenate([transform_points(p, q) for p, q in zip(poses, scans, strict=True)])
    return thin_to_grid(pts, spacing)


def _link_sequences(
    feats: np.ndarray,
    poses: np.ndarray,
    seq: np.ndarray,
    ranges: np.ndarray,
    points: list,
    dense: list,
    beam_step: float,
    s: MapSettings,
) -> tuple[list, list]:
    """Return the edges between views of different sequences that see the same place.

    The sequences are first aligned by sensing (`_sequence_alignment`); then each view is
    linked to the
    view of the other sequence nearest in image features among those within ``link_radius``
    under that alignment, kept when ICP of the two scans (seeded by the alignment, so it
    cannot slide along a uniform corridor) converges with a small residual.
    """
    edges, transforms = [], []
    seqs = np.unique(seq)
    for a in seqs:
        for b in seqs[seqs > a]:
            ia, ib = np.flatnonzero(seq == a), np.flatnonzero(seq == b)
            align = _sequence_alignment(feats, poses, ia, ib, ranges, points, dense, beam_step, s)
            if align is None:
                continue
            placed = se2_compose(align, poses[ib])  # b's views in a's frame
            for i in ia:
                near = ib[np.hypot(*(placed[:, :2] - poses[i, :2]).T) < s.link_radius]
                if len(near) == 0:
                    continue
                d = np.sum((feats[near] - feats[i]) ** 2, axis=1)
                j = int(near[np.argmin(d)])
                init = se2_relative(poses[i], placed[ib == j][0])
                res = icp(points[j], dense[i], init=init)
                if _verified(res, len(points[j]), s):
                    edges.append((int(i), j))
                    transforms.append(res.transform)
    return edges, transforms


def sequence_origin(odometry: np.ndarray) -> np.ndarray:
    """Return odometry re-expressed from its own first pose.

    A recording knows where it went, not where it started (the dataset's simulated odometry
    starts at the true pose).

    Parameters
    ----------
    odometry : array_like of shape (n, 3)
        The recording's odometry poses (x, y, yaw).

    Returns
    -------
    ndarray of shape (n, 3)
        The poses relative to the first one, float64.
    """
    odometry = np.asarray(odometry, np.float64)
    return se2_relative(odometry[0], odometry)


def build_map(
    dataset: Dataset | str | os.PathLike, world: str, settings: MapSettings | None = None
) -> ServoMap:
    """Fit the servo map of ``world`` from a dataset (see the module docstring).

    Parameters
    ----------
    dataset : Dataset or str or os.PathLike
        The dataset, or the folder to load it from.
    world : str
        The world's name (``"hallway"``, ``"lawn"`` or ``FAMILY:SEED``).
    settings : MapSettings or None, default None
        The map's settings; None: ``MapSettings()``.

    Returns
    -------
    ServoMap
        The fitted map.

    Raises
    ------
    DatasetError
        When the dataset cannot give what a map needs (`servo.maps.needs`: beams, frames per
        manifold), naming the shortfall.
    """
    world = check_world_name(world)
    settings = settings or MapSettings()
    if not isinstance(dataset, Dataset):
        dataset = load_dataset(dataset)
    for sensor in ("camera", "laser"):  # views are images; their links, scan matches
        dataset.require(sensor, "the servo map")
    names = _world_sequences(dataset, world)
    first = dataset.sequences[names[0]]
    max_range = dataset.max_range
    if max_range is None:  # a meta.json from another writer: no laser settings recorded
        raise DatasetError(f"{dataset.path}: meta.json gives no settings.laser.max_range")
    check_needs(dataset, world, names, settings)
    cols: dict[str, list] = {k: [] for k in ("images", "scans", "poses", "true", "labels")}
    seq_ids, frames = [], []
    for k, name in enumerate(names):
        s = dataset.sequences[name]
        keep = np.arange(0, len(s), settings.stride)
        pts = [scan_to_points(r, s.angles, max_range) for r in s.scans]
        # Scan-matched odometry: the increments between stored views are what the controller
        # chains along a route, so make them as good as the recording allows.
        refined = refine_poses(pts, sequence_origin(s.odometry))
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

    image_features = ImageFeatures(size=tuple(settings.image_size), normalization="unit")
    feats = image_features.fit_transform(images).astype(np.float32)
    # The combination the servo tables (docs/guides/servo.md) were measured with; the estimator's
    # default, "spectral", changes the views' clusters. Switch when the servo evaluation is
    # re-run.
    # K is a stated prior (MapSettings.n_clusters), never counted from the labels: the truth
    # is kept for the evaluation only.
    clustering = ManifoldClustering(
        n_clusters=settings.clusters_for(world),
        min_cluster_size=settings.min_cluster_size,
        combine="separability",
    ).fit(feats)

    points = [scan_to_points(r, first.angles, max_range) for r in scans]
    dense = [densify_scan(p) for p in points]
    edges, transforms = [], []
    for i in range(len(seq) - 1):
        if seq[i] == seq[i + 1]:
            edges.append((i, i + 1))
            transforms.append(se2_relative(poses[i], poses[i + 1]))
    ranges = clip_ranges(scans, max_range)
    beam_step = float(np.median(np.diff(first.angles)))
    links, link_t = _link_sequences(feats, poses, seq, ranges, points, dense, beam_step, settings)
    return ServoMap(
        world=world,
        world_digest=world_digest(world),
        manifold_names=tuple(dataset.manifolds),
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
    """Return the cached map of ``world`` for this dataset and settings, built on first use.

    ``dataset`` and ``cache`` default to the data home's (``sim.datahome``: the ``home``
    argument, then ``TOPOMAP_HOME``, then the per-user cache), never the working directory;
    the default dataset is collected there when missing. A cached map that fails
    [`load_map`][servo.maps.file.load_map]'s checks is rebuilt, with a warning saying why.

    Parameters
    ----------
    world : str
        The world's name (``"hallway"``, ``"lawn"`` or ``FAMILY:SEED``).
    dataset : str or os.PathLike or None, default None
        The dataset folder; None: the data home's default dataset.
    cache : str or os.PathLike or None, default None
        The folder of cached maps; None: the data home's.
    settings : MapSettings or None, default None
        The map's settings; None: ``MapSettings()``.
    home : str or os.PathLike or None, default None
        The data home; None: ``TOPOMAP_HOME``, then the per-user cache.
    progress : bool, default True
        Print a line to stderr when building (and collecting the default dataset).

    Returns
    -------
    ServoMap
        The cached or freshly built map.
    """
    world = check_world_name(world)
    settings = settings or MapSettings()
    if dataset is None:
        dataset = datahome.default_dataset(home, progress=progress)
    dataset = Path(dataset)
    if dataset.exists() and not dataset.is_dir():
        raise ValueError(f"dataset must be a dataset folder, got the file {dataset}")
    cache = datahome.maps_dir(home) if cache is None else Path(cache)
    if cache.exists() and not cache.is_dir():
        raise ValueError(f"cache must be a folder for servo maps, got the file {cache}")
    try:
        key = map_key(read_meta(dataset), world, settings)
    except MapError as err:  # no sequence of the world: name the dataset
        raise MapError(f"{dataset}: {err}") from None
    path, _ = map_paths(cache, world, key)
    if path.is_file():
        try:
            return load_map(path, world)
        except MapError as err:
            warnings.warn(f"rebuilding the servo map: {err}", RuntimeWarning, stacklevel=2)
    cache.mkdir(parents=True, exist_ok=True)
    with datahome.folder_lock(cache, f"the {world} servo map"):  # one builder, the others wait
        if path.is_file():
            try:
                return load_map(path, world)  # built by the process this one waited for
            except MapError:
                pass
        if progress:
            print(
                f"topomap: building the {world} servo map into {cache} (once)",
                file=sys.stderr,
                flush=True,
            )
        m = build_map(load_dataset(dataset), world, settings)
        save_map(m, cache)
    return m
