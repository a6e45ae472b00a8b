"""The servo map on disk: ``<world>-<key>.npz`` (arrays) and ``<world>-<key>.json`` (the rest).

No pickle anywhere. A map file is untrusted input: [`load_map`][servo.maps.file.load_map] checks the
JSON's schema, the ``.npz``'s SHA-256 against the one recorded at save time, every array's dtype and
shape against the others and its values against `common.bounds` and the map's own indices (views,
sequences, manifolds), checks the description's own SHA-256, rebuilds the estimators only through
`mapping.persistence` (an exact set of known classes), and finally re-runs the feature transform and
the clustering's ``predict`` on a few stored views and compares with what was saved. Whatever fails
raises [`MapError`][servo.maps.types.MapError] naming the file and the fault.
"""

from __future__ import annotations

import hashlib
import json
import os
import re
from pathlib import Path

import numpy as np

from common import bounds
from common.fileio import UnreadableJSON, atomic_write_bytes, read_json
from common.validation import is_real
from mapping import persistence
from mapping.features import ImageFeatures
from mapping.manifold import ManifoldClustering
from scenes import NO_MANIFOLD
from scenes.families import check_world_name, parse_world_name
from servo.maps.types import MapError, MapSettings, ServoMap
from sim.collect_worlds import world_digest
from sim.dataset import read_npz, write_sequence

FORMAT = "topomap-servo-map"
# 3: sequences aligned by sensing only (each odometry from its own origin); 4: the world's
# floor-plan digest and the names the true labels index (generated worlds)
FORMAT_VERSION = 4
PROBE_VIEWS = 8  # stored views re-checked through the loaded estimators
_ARRAYS = {  # name: (dtype kinds allowed, shape pattern); n = views, B = beams, E = edges
    "images": ("u", ("n", "H", "W", 3)),
    "features": ("f", ("n", "d")),
    "scans": ("f", ("n", "B")),
    "angles": ("f", ("B",)),
    "poses": ("f", ("n", 3)),
    "sequence": ("iu", ("n",)),
    "frame": ("iu", ("n",)),
    "clusters": ("iu", ("n",)),
    "edges": ("iu", ("E", 2)),
    "edge_transforms": ("f", ("E", 3)),
    "true_poses": ("f", ("n", 3)),
    "true_labels": ("iu", ("n",)),
}
_META_KEYS = {
    "format",
    "version",
    "world",
    "world_digest",
    "manifolds",
    "key",
    "max_range",
    "sequence_names",
    "settings",
    "clustering",
    "image_features",
    "sha256",
    "probe",
    "meta_sha256",
}
_KEY = re.compile(r"[0-9a-f]{16}\Z")
_SHA = re.compile(r"[0-9a-f]{64}\Z")


def map_paths(directory: str | os.PathLike, world: str, key: str) -> tuple[Path, Path]:
    """Return the paths of the ``.json`` and ``.npz`` files of the map of ``world`` and ``key``.

    Parameters
    ----------
    directory : str or os.PathLike
        The folder of the map files.
    world : str
        The world's name (a ``FAMILY:SEED`` name is written without the ``:``).
    key : str
        The map's cache key ([`map_key`][servo.maps.build.map_key]).

    Returns
    -------
    json_path, npz_path : Path
        ``<directory>/<world>-<key>.json`` and ``.npz``.
    """
    stem = Path(directory) / f"{parse_world_name(world).file_stem}-{key}"  # no ':' in files
    return stem.with_suffix(".json"), stem.with_suffix(".npz")


def _probe(clustering: ManifoldClustering, features: np.ndarray) -> list[int]:
    """Return the clusters predicted for the first stored views: a loaded map must match them."""
    return [int(c) for c in clustering.predict(features[:PROBE_VIEWS])]


def meta_digest(meta: dict) -> str:
    """Return the SHA-256 of a map's description itself (all but this field, canonical JSON).

    An edited or damaged ``.json`` is thus caught like a damaged ``.npz``.

    Parameters
    ----------
    meta : dict
        The map's ``.json`` content.

    Returns
    -------
    str
        64 hex digits.
    """
    body = {k: v for k, v in meta.items() if k != "meta_sha256"}
    return hashlib.sha256(json.dumps(body, sort_keys=True).encode()).hexdigest()


def save_map(m: ServoMap, directory: str | os.PathLike) -> Path:
    """Write ``<world>-<key>.npz`` and ``.json`` atomically.

    Parameters
    ----------
    m : ServoMap
        The map to write.
    directory : str or os.PathLike
        The folder to write it into (created if missing).

    Returns
    -------
    Path
        The ``.json`` path.
    """
    directory = Path(directory)
    directory.mkdir(parents=True, exist_ok=True)
    json_path, npz_path = map_paths(directory, m.world, m.key)
    arrays = {k: getattr(m, k) for k in _ARRAYS}
    c_meta, c_arrays = persistence.dump(m.clustering, "clustering")
    f_meta, f_arrays = persistence.dump(m.image_features, "image_features")
    digest = write_sequence(npz_path, {**arrays, **c_arrays, **f_arrays})
    meta = {
        "format": FORMAT,
        "version": FORMAT_VERSION,
        "world": m.world,
        "world_digest": m.world_digest,
        "manifolds": list(m.manifold_names),
        "key": m.key,
        "max_range": m.max_range,
        "sequence_names": m.sequence_names,
        "settings": m.settings.to_json(),
        "clustering": c_meta,
        "image_features": f_meta,
        "sha256": digest,
        "probe": _probe(m.clustering, m.features),
    }
    meta["meta_sha256"] = meta_digest(meta)
    atomic_write_bytes(json_path, (json.dumps(meta, indent=2) + "\n").encode())
    return json_path


# -- loading (untrusted) ----------------------------------------------------------------------
def _check(cond: bool, path: Path, what: str) -> None:
    if not cond:
        raise MapError(f"{path} is not a valid servo map: {what}")


def _read_meta(path: Path, world: str | None) -> dict:
    try:
        meta = read_json(path)
    except UnreadableJSON as err:  # a MapError: load_or_build rebuilds as for any damage
        raise MapError(f"{path} is not a valid servo map: not JSON ({err})") from err
    _check(isinstance(meta, dict), path, "the JSON must be an object")
    _check(meta.get("format") == FORMAT, path, f"format must be {FORMAT!r}")
    if meta.get("version") != FORMAT_VERSION:
        raise MapError(
            f"{path} is a servo map of format version {meta.get('version')!r}; this code reads "
            f"version {FORMAT_VERSION}: delete it and build the map again"
        )
    _check(set(meta) == _META_KEYS, path, f"expected exactly the keys {sorted(_META_KEYS)}")
    if meta["meta_sha256"] != meta_digest(meta):
        raise MapError(f"{path} is truncated or modified: its meta_sha256 does not match")
    try:
        named = check_world_name(meta["world"]) == meta["world"]  # the normalised spelling
    except ValueError:
        named = False
    _check(named, path, "world must be 'hallway', 'lawn' or FAMILY:SEED such as 'hallway:17'")
    _check(
        isinstance(meta["world_digest"], str) and bool(_SHA.match(meta["world_digest"])),
        path,
        "world_digest must be 64 hex digits",
    )
    manifolds = meta["manifolds"]
    _check(
        isinstance(manifolds, list) and all(isinstance(n, str) for n in manifolds),
        path,
        "manifolds must be a list of names",
    )
    if world is not None and (
        meta["world"] != world or meta["world_digest"] != world_digest(world)
    ):
        raise MapError(
            f"{path} is a servo map of the {meta['world']!r} world (floor plan "
            f"{meta['world_digest'][:12]}), not of the {world!r} world (floor plan "
            f"{world_digest(world)[:12]}): build the map from the {world!r} dataset"
        )
    _check(isinstance(meta["key"], str) and bool(_KEY.match(meta["key"])), path, "bad key")
    _check(
        isinstance(meta["sha256"], str) and bool(_SHA.match(meta["sha256"])),
        path,
        "sha256 must be 64 hex digits",
    )
    r = meta["max_range"]
    # an int is compared as an int: np.isfinite(10**400) raises TypeError
    _check(
        is_real(r) and 0 < r <= bounds.MAX_RANGE,
        path,
        f"max_range must be a number of metres in (0, {bounds.MAX_RANGE:g}], got {repr(r)[:40]}",
    )
    names = meta["sequence_names"]
    _check(
        isinstance(names, list) and all(isinstance(n, str) for n in names),
        path,
        "sequence_names must be a list of strings",
    )
    probe = meta["probe"]
    _check(
        isinstance(probe, list) and all(isinstance(c, int) for c in probe),
        path,
        "probe must be a list of cluster indices",
    )
    return meta


def _check_arrays(arrays: dict, path: Path, manifolds: int, sequences: int) -> None:
    dims: dict[str, int] = {}
    for name, (kinds, pattern) in _ARRAYS.items():
        _check(name in arrays, path, f"array {name!r} is missing")
        a = arrays[name]
        _check(
            a.dtype.kind in kinds and a.ndim == len(pattern),
            path,
            f"{name} must be a {len(pattern)}-d array of kind {kinds!r}, got {a.dtype} "
            f"with shape {a.shape}",
        )
        for size, want in zip(a.shape, pattern, strict=True):
            if isinstance(want, int):
                _check(size == want, path, f"{name} has shape {a.shape}, expected {pattern}")
            else:
                _check(
                    dims.setdefault(want, size) == size,
                    path,
                    f"{name} has shape {a.shape}; {want} is {dims[want]} elsewhere",
                )
    n = dims["n"]
    _check(n > 0, path, "the map has no stored view")
    edges = arrays["edges"]
    _check(bool(np.all((edges >= 0) & (edges < n))), path, "edges name views outside the map")
    clusters = arrays["clusters"]
    _check(bool(np.all(clusters >= 0)), path, "clusters must be >= 0")
    _check(bool(np.all(arrays["frame"] >= 0)), path, "frame must be >= 0 (a frame index)")
    _check(
        bool(np.all((arrays["sequence"] >= 0) & (arrays["sequence"] < sequences))),
        path,
        f"sequence must lie in [0, {sequences}): an index into the map's {sequences} "
        "sequence_names",
    )
    labels = arrays["true_labels"]
    _check(
        bool(np.all((labels >= NO_MANIFOLD) & (labels < manifolds))),
        path,
        f"true_labels must lie in [{NO_MANIFOLD}, {manifolds}): an index into the map's "
        f"manifolds, {NO_MANIFOLD} for none",
    )
    for name in ("features", "edge_transforms"):
        _check(bool(np.isfinite(arrays[name]).all()), path, f"{name} holds NaN or inf")
    # the bounds every reader applies (common.bounds); ranges as the dataset stores them: +inf
    # is no return, NaN and < 0 are refused (the map's views need their points)
    problem = (
        bounds.pose_problem(arrays["poses"], "poses")
        or bounds.pose_problem(arrays["true_poses"], "true_poses")
        or bounds.angle_problem(arrays["angles"], "angles")
        or bounds.range_problem(arrays["scans"], "scans")
    )
    _check(problem is None, path, str(problem))


def _check_clusters(clusters: np.ndarray, clustering: ManifoldClustering, path: Path) -> None:
    """Check that every stored view's cluster is one of the loaded clustering's.

    The arrays are checked before the estimators are rebuilt, so this comes after.
    """
    k = len(clustering.centers_)
    _check(
        bool(np.all(clusters < k)),
        path,
        f"clusters must lie in [0, {k}), the clustering's clusters",
    )


def load_map(path: str | os.PathLike, world: str | None = None) -> ServoMap:
    """Read and verify a map written by [`save_map`][servo.maps.file.save_map].

    See the module docstring for the checks.

    Parameters
    ----------
    path : str or os.PathLike
        The ``.json`` (or ``.npz``) of the map.
    world : str or None, default None
        If given, the map must be of this world.

    Returns
    -------
    ServoMap
        The verified map.

    Raises
    ------
    MapError
        Naming the file and the fault, when a check fails.
    """
    if world is not None:
        # an argument error, not a damaged file: no MapError (load_or_build would rebuild)
        world = check_world_name(world, "world")  # its ValueError names the accepted forms
    path = Path(path).with_suffix(".json")
    npz_path = path.with_suffix(".npz")
    if not path.is_file():
        raise MapError(f"no servo map at {path}")
    meta = _read_meta(path, world)
    arrays = read_npz(npz_path, meta["sha256"], "the servo map's arrays ", MapError)
    _check_arrays(arrays, npz_path, len(meta["manifolds"]), len(meta["sequence_names"]))
    try:
        settings = MapSettings.from_json(meta["settings"])
        clustering = persistence.load(ManifoldClustering, meta["clustering"], arrays, "clustering")
        image_features = persistence.load(
            ImageFeatures, meta["image_features"], arrays, "image_features"
        )
    except (TypeError, ValueError) as err:
        raise MapError(f"{path} is not a valid servo map: {err}") from err
    _check_clusters(arrays["clusters"], clustering, npz_path)
    m = ServoMap(
        world=meta["world"],
        world_digest=meta["world_digest"],
        manifold_names=tuple(meta["manifolds"]),
        key=meta["key"],
        max_range=float(meta["max_range"]),
        sequence_names=list(meta["sequence_names"]),
        clustering=clustering,
        image_features=image_features,
        settings=settings,
        **{k: arrays[k] for k in _ARRAYS},
    )
    try:
        features = image_features.transform(m.images[:PROBE_VIEWS])
        probe = _probe(clustering, m.features)
    except Exception as err:  # a wrong shape or value anywhere in the estimators' state
        raise MapError(
            f"{path}: the stored estimators do not work ({type(err).__name__}: {err})"
        ) from err
    if not np.allclose(features, m.features[:PROBE_VIEWS], rtol=1e-4, atol=1e-6) or (
        probe != meta["probe"]
    ):
        raise MapError(
            f"{path}: the loaded estimators do not reproduce the saved map's features and "
            "clusters on its first views: the file was modified or written by other code"
        )
    return m
