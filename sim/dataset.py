"""The on-disk dataset: one ``.npz`` per sequence and a ``meta.json``, loaded without pickle.

Layout of a dataset directory (schema version :data:`SCHEMA_VERSION`)::

    meta.json            settings (world, seed, sensors, teleop), the manifold names, and per
                         sequence its file, world, frame count and SHA-256
    hallway-left.npz     one file per sequence, arrays indexed by frame:
        images    uint8   (N, H, W, 3)  RGB camera frames
        depth     float32 (N, H, W)     metric depth (only when collected with depth)
        scans     float32 (N, B)        laser ranges, +inf = no return within max range
        angles    float32 (B,)          beam angles in the sensor frame (rad, CCW, 0 = ahead)
        poses     float64 (N, 3)        true pose (x, y, yaw) in the world frame (*)
        odometry  float64 (N, 3)        odometry pose (starts at the true start pose)
        commands  float64 (N, 2)        command (v m/s, omega rad/s) being executed
        labels    int16   (N,)          ground-truth manifold id (index into meta "manifolds"),
                                        -1 if on no manifold (*)
        times     float64 (N,)          simulation time (s)

(*) ground truth: present when ``meta["ground_truth"]`` is true (collected in simulation); a
dataset imported from a robot's log (:mod:`sim.readers.rosbag`) has ``"ground_truth": false``,
no ``poses`` or ``labels`` arrays and no manifolds. A dataset of a robot without a camera (a
laser-only bag) has ``"camera": false`` and no ``images`` arrays (absent: true). Schema
version 1 (before ``"ground_truth"`` existed) is still read, as a dataset with ground truth.

Reading checks the values too, against :mod:`common.bounds`: finite poses, odometry, commands,
times and angles within their bounds, times that never go backwards, ranges that are never NaN
or negative (``+inf``: no return), labels within the manifolds, images and scans that are not
empty. Anything else raises :class:`DatasetError` naming the file and the array.

Every file is written to a temporary name and renamed, and ``meta.json`` lists a sequence only
after its file is complete, so an interrupted collection never leaves a half-written sequence.
"""

from __future__ import annotations

import hashlib
import os
import re
import zipfile
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from common import bounds
from common.fileio import UnreadableJSON, atomic_path, read_json
from common.npz import UnreadableNpz, read_arrays
from sim.runs import Runs

SCHEMA_VERSION = 2
READABLE_VERSIONS = (1, 2)  # version 2 added "ground_truth" (false: no poses, no labels)
FORMAT_NAME = "topomap-dataset"
META_FILE = "meta.json"
ARRAYS = {  # name: (dtype, trailing shape rank or None for per-dataset constants)
    "images": np.uint8,
    "scans": np.float32,
    "angles": np.float32,
    "poses": np.float64,
    "odometry": np.float64,
    "commands": np.float64,
    "labels": np.int16,
    "times": np.float64,
}
PER_FRAME = ("images", "scans", "poses", "odometry", "commands", "labels", "times")
SHAPES = {  # trailing shape per frame (angles: per dataset); -1: any size, checked against others
    "images": (-1, -1, 3),
    "scans": (-1,),
    "angles": (-1,),
    "poses": (3,),
    "odometry": (3,),
    "commands": (2,),
    "labels": (),
    "times": (),
}
_FILE_NAME = re.compile(r"[A-Za-z0-9][A-Za-z0-9_.-]{0,200}\.npz\Z")  # the file system's limit
_NAME = re.compile(r"[A-Za-z0-9][A-Za-z0-9_.-]{0,200}\Z")
_SHA256 = re.compile(r"[0-9a-f]{64}\Z")
GROUND_TRUTH = ("poses", "labels")  # absent from a dataset without ground truth


class DatasetError(ValueError):
    """A dataset that is missing, truncated, inconsistent or from another schema version."""


@dataclass
class Sequence:
    """One recorded sequence (one drive) of a dataset, its arrays indexed by frame.

    The arrays and their units are those of the dataset format (the module's description).

    Parameters
    ----------
    name, world : str
        The sequence's name (e.g. ``"lawn-left"``) and the world (place) it was recorded in.
    images, scans, angles, odometry, commands, times : ndarray
        The arrays of the dataset format, in its units (the module's description); ``images``
        is None in a dataset without a camera.
    poses, labels : ndarray or None, default None
        The true poses and manifold ids; None without ground truth.
    depth : ndarray or None, default None
        Metric depth, when collected with depth.

    Attributes
    ----------
    name, world, images, scans, angles, odometry, commands, times, poses, labels, depth
        The parameters.

    Examples
    --------
    >>> import sim  # headless rendering, chosen before anything imports mujoco
    >>> from sim.collect import CollectionSettings, collect_dataset
    >>> from sim.dataset import load_dataset
    >>> data = collect_dataset("lawn-40", CollectionSettings(worlds=("lawn",), frames=40),
    ...                        jobs=1, progress=False)  # three drives of 40 frames, ~10 s
    >>> ds = load_dataset(data)
    >>> sequence = ds.sequences["lawn-left"]
    >>> len(sequence), sequence.images.shape, sequence.scans.shape
    (40, (40, 240, 320, 3), (40, 361))

    See Also
    --------
    sim.dataset.Dataset : The sequences of a dataset.
    """

    name: str
    world: str
    images: np.ndarray | None  # None without a camera
    scans: np.ndarray
    angles: np.ndarray
    odometry: np.ndarray
    commands: np.ndarray
    times: np.ndarray
    poses: np.ndarray | None = None  # None without ground truth
    labels: np.ndarray | None = None  # None without ground truth
    depth: np.ndarray | None = None

    def __len__(self) -> int:
        return len(self.times)


@dataclass
class Dataset:
    """A loaded dataset: its ``meta.json`` and its sequences by name.

    Made by :func:`load_dataset`, which verifies every file's checksum.

    Parameters
    ----------
    path : Path
        The dataset's directory.
    meta : dict
        The parsed ``meta.json``.
    sequences : dict of str to Sequence
        The sequences, in ``meta`` order.

    Attributes
    ----------
    path, meta, sequences
        The parameters.
    manifolds : list of str
        The manifolds' names (label ``i`` is ``manifolds[i]``).
    has_ground_truth : bool
        True poses and manifold labels are recorded (simulated data, not imported logs).
    has_camera : bool
        Camera images are recorded (false for a laser-only import).
    max_range : float or None
        The laser's range from the settings, m.
    worlds : list of str
        The worlds of the sequences, in order of first appearance.

    Examples
    --------
    >>> import sim  # headless rendering, chosen before anything imports mujoco
    >>> from sim.collect import CollectionSettings, collect_dataset
    >>> from sim.dataset import load_dataset
    >>> data = collect_dataset("lawn-40", CollectionSettings(worlds=("lawn",), frames=40),
    ...                        jobs=1, progress=False)  # three drives of 40 frames, ~10 s
    >>> ds = load_dataset(data)
    >>> list(ds.sequences), ds.worlds
    (['lawn-left', 'lawn-straight', 'lawn-right'], ['lawn'])
    >>> train, test = ds.paper_split()
    >>> ds.concat("images")[train].shape, int(test.sum())
    ((60, 240, 320, 3), 60)

    See Also
    --------
    sim.dataset.load_dataset : Reads and verifies a dataset.
    sim.collect.collect_dataset : Records one.
    sim.readers.import_rosbags : Imports a robot's ROS bags as one.
    """

    path: Path
    meta: dict
    sequences: dict[str, Sequence]

    @property
    def manifolds(self) -> list[str]:
        """The manifolds' names: label ``i`` is ``manifolds[i]``."""
        return list(self.meta["manifolds"])

    @property
    def has_ground_truth(self) -> bool:
        """True poses and manifold labels are recorded (simulated data; not imported logs)."""
        return bool(self.meta.get("ground_truth", True))

    @property
    def has_camera(self) -> bool:
        """Camera images are recorded (false for a dataset imported without a camera)."""
        return bool(self.meta.get("camera", True))

    @property
    def max_range(self) -> float | None:
        """The laser's maximum range (m) from the settings; readings at or beyond it are no
        return. None when the settings do not say."""
        value = self.meta.get("settings", {}).get("laser", {}).get("max_range")
        return None if value is None else float(value)

    @property
    def worlds(self) -> list[str]:
        """The worlds (places) of the sequences, in order of first appearance."""
        return list(dict.fromkeys(s.world for s in self.sequences.values()))

    def concat(self, field: str, names: list[str] | None = None) -> np.ndarray:
        """One array of ``field`` over sequences (in ``meta`` order, or ``names``)."""
        names = list(self.sequences) if names is None else names
        if field in GROUND_TRUTH and not self.has_ground_truth:
            raise DatasetError(f"{self.path} has no ground truth: no {field!r} to concatenate")
        if field == "images" and not self.has_camera:
            raise DatasetError(
                f"{self.path} has no camera images (imported without an image topic): the "
                "methods on images need a dataset with a camera; the laser scans are there"
            )
        return np.concatenate([getattr(self.sequences[n], field) for n in names])

    def runs(self, world: str) -> Runs:
        """Every sequence (drive) of ``world`` together, in the form the mapping methods take.

        See :class:`Runs`; no-return beams (``inf``, and readings at or beyond the dataset's
        :attr:`max_range`) are left out of the scan points.
        """
        sequences = [s for s in self.sequences.values() if s.world == world]
        if not sequences:
            raise ValueError(
                f"{self.path} has no sequence in world {world!r}: it has {self.worlds}"
            )
        return Runs.from_sequences(sequences, self.max_range)

    def paper_split(self) -> tuple[np.ndarray, np.ndarray]:
        """Boolean masks (train, test) over :meth:`concat` order: every second frame of each
        sequence builds the map (frames 0, 2, 4, ...) and the others test it, as in the paper."""
        train = np.concatenate([np.arange(len(s)) % 2 == 0 for s in self.sequences.values()])
        return train, ~train


# -- writing ---------------------------------------------------------------------------------
def write_sequence(path: Path, arrays: dict[str, np.ndarray], compresslevel: int = 1) -> str:
    """Write arrays as an ``.npz`` (deflate level 1: most of the size win at a fraction of the
    time), atomically; return its SHA-256."""
    with atomic_path(path) as tmp:
        with zipfile.ZipFile(tmp, "w", zipfile.ZIP_DEFLATED, compresslevel=compresslevel) as zf:
            for key in sorted(arrays):
                info = zipfile.ZipInfo(f"{key}.npy", date_time=(1980, 1, 1, 0, 0, 0))
                info.compress_type = zipfile.ZIP_DEFLATED
                with zf.open(info, "w", force_zip64=True) as f:
                    np.lib.format.write_array(
                        f, np.ascontiguousarray(arrays[key]), allow_pickle=False
                    )
        digest = file_sha256(tmp)
    return digest


def file_sha256(path: Path) -> str:
    h = hashlib.sha256()
    with open(path, "rb") as f:
        for chunk in iter(lambda: f.read(1 << 22), b""):
            h.update(chunk)
    return h.hexdigest()


# -- reading ---------------------------------------------------------------------------------
def read_meta(directory: str | os.PathLike) -> dict:
    path = Path(directory) / META_FILE
    if Path(directory).is_file():
        raise DatasetError(f"{directory} is a file, not a dataset folder")
    if not path.is_file():
        raise DatasetError(f"no dataset at {directory}: {META_FILE} is missing")
    try:
        meta = read_json(path)
    except UnreadableJSON as err:
        raise DatasetError(f"{path} is not valid JSON: {err}") from err
    if not isinstance(meta, dict):
        raise DatasetError(f"{path} must hold a JSON object, got a {type(meta).__name__}")
    if meta.get("format") != FORMAT_NAME:
        raise DatasetError(f"{path} is not a {FORMAT_NAME} (format={meta.get('format')!r})")
    version = meta.get("schema_version")
    if isinstance(version, bool) or version not in READABLE_VERSIONS:  # True == 1 in Python
        raise DatasetError(
            f"{directory} has schema version {meta.get('schema_version')!r}; this code reads "
            f"versions {READABLE_VERSIONS}: collect it again with this version"
        )
    if meta["schema_version"] >= 2 and not isinstance(meta.get("ground_truth"), bool):
        raise DatasetError(
            f"{path}: 'ground_truth' must be true or false in schema version 2, got "
            f"{meta.get('ground_truth')!r}"
        )
    if "sequences" not in meta:  # every writer records it, even before the first sequence
        raise DatasetError(
            f"{path}: the key 'sequences' (an object of sequence entries) is missing"
        )
    sequences = meta["sequences"]
    if not isinstance(sequences, dict):
        raise DatasetError(f"{path}: 'sequences' must be an object of sequence entries")
    for name, entry in sequences.items():
        check_entry(path, name, entry)
    _check_optional_keys(path, meta)
    return meta


def _check_optional_keys(path: Path, meta: dict) -> None:
    """The other keys the code reads, where present: ``settings`` (its ``laser`` and that
    one's ``max_range``, the laser's range), ``manifolds`` and ``complete``. They may be
    absent (a dataset of schema version 1, a collection just started)."""
    settings = meta.get("settings", {})
    if not isinstance(settings, dict):
        raise DatasetError(f"{path}: 'settings' must be an object, got {settings!r}")
    laser = settings.get("laser", {})
    if not isinstance(laser, dict):
        raise DatasetError(f"{path}: 'settings.laser' must be an object, got {laser!r}")
    r = laser.get("max_range", 1.0)
    if isinstance(r, bool) or not isinstance(r, int | float) or not 0 < r < float("inf"):
        raise DatasetError(f"{path}: 'settings.laser.max_range' must be a positive number (m), "
                           f"got {r!r}")  # fmt: skip
    manifolds = meta.get("manifolds", [])
    if not (isinstance(manifolds, list) and all(isinstance(m, str) for m in manifolds)):
        raise DatasetError(f"{path}: 'manifolds' must be a list of names, got {manifolds!r}")
    if not isinstance(meta.get("camera", True), bool):
        raise DatasetError(f"{path}: 'camera' must be true or false, got {meta['camera']!r}")
    if not isinstance(meta.get("complete", False), bool):
        raise DatasetError(f"{path}: 'complete' must be true or false, got {meta['complete']!r}")


def check_entry(path: Path, name: str, entry) -> None:
    """A sequence entry of ``meta.json``: a plain ``.npz`` file name inside the dataset folder
    (never a path elsewhere), a world name, a frame count and a SHA-256."""
    fields = ("file", "world", "frames", "sha256")
    if not isinstance(entry, dict) or any(k not in entry for k in fields):
        raise DatasetError(f"{path}: sequence {name!r} must have the fields {list(fields)}")
    file, world, frames, digest = (entry[k] for k in fields)
    if not (isinstance(file, str) and _FILE_NAME.match(file)):
        raise DatasetError(
            f"{path}: sequence {name!r} names the file {file!r}; expected a plain file name "
            "ending in .npz inside the dataset folder"
        )
    if not (isinstance(world, str) and _NAME.match(world)):
        raise DatasetError(f"{path}: sequence {name!r} has the world {world!r}")
    if isinstance(frames, bool) or not isinstance(frames, int) or frames < 0:
        raise DatasetError(f"{path}: sequence {name!r} has {frames!r} frames; expected >= 0")
    if not (isinstance(digest, str) and _SHA256.match(digest)):
        raise DatasetError(f"{path}: sequence {name!r} has no valid sha256")


def read_npz(
    path: Path, sha256: str | None, context: str = "", error: type[Exception] = DatasetError
) -> dict[str, np.ndarray]:
    """The arrays of an ``.npz`` (as :func:`write_sequence` writes them), read without pickle
    after checking its SHA-256 when ``sha256`` is given; a missing, modified or unreadable file
    raises ``error`` starting with ``context``."""
    if not path.is_file():
        raise error(f"{context}{path} is missing")
    if sha256 is not None and file_sha256(path) != sha256:
        raise error(f"{context}{path} is truncated or modified (checksum mismatch)")
    try:
        return read_arrays(path)
    except UnreadableNpz as err:
        raise error(f"{context}{path} cannot be read ({err})") from err


def _value_problem(arrays: dict[str, np.ndarray], manifolds: int | None) -> str | None:
    """What is wrong with the values of a sequence's arrays (:mod:`common.bounds`), or None;
    ``manifolds``: how many there are (labels must lie in ``[-1, manifolds)``), None: any."""
    image_shape = arrays["images"].shape[1:] if "images" in arrays else (1, 1, 3)
    if 0 in image_shape[:2] or len(arrays["angles"]) == 0:
        return (
            f"images of shape {image_shape} and scans of {len(arrays['angles'])} beams: "
            "neither may be empty"
        )
    labels = arrays.get("labels")
    if labels is not None and manifolds is not None and len(labels):
        low, high = int(labels.min()), int(labels.max())
        if low < -1 or high >= manifolds:
            return (
                f"labels from {low} to {high}, but meta.json has {manifolds} manifolds: a label "
                f"is -1 (on none) or in 0..{manifolds - 1}"
            )
    checks = [
        ("scans", bounds.range_problem), ("angles", bounds.angle_problem),
        ("odometry", bounds.pose_problem), ("poses", bounds.pose_problem),
        ("commands", bounds.command_problem), ("times", bounds.time_problem),
        ("depth", bounds.range_problem),
    ]  # fmt: skip
    for key, check in checks:
        problem = check(arrays[key], key) if key in arrays else None
        if problem:
            return problem
    return None


def load_sequence(
    directory: Path,
    name: str,
    entry: dict,
    verify: bool = True,
    ground_truth: bool = True,
    manifolds: int | None = None,
    camera: bool = True,
) -> Sequence:
    """One sequence's file, checked against its ``meta.json`` entry; ``ground_truth`` says
    whether ``poses`` and ``labels`` must be there (True) or must not (False); ``manifolds``
    how many manifolds its labels may name (None: not checked); ``camera`` whether ``images``
    must be there (True) or must not (False)."""
    path = Path(directory) / entry["file"]
    arrays = read_npz(path, entry["sha256"] if verify else None, f"sequence {name!r}: ")
    expected = [
        k for k in ARRAYS if (ground_truth or k not in GROUND_TRUTH) and (camera or k != "images")
    ]
    missing = [k for k in expected if k not in arrays]
    if missing:
        raise DatasetError(f"sequence {name!r}: arrays {missing} missing from {path}")
    extra = [k for k in GROUND_TRUTH if k in arrays and not ground_truth]
    if extra:
        raise DatasetError(
            f"sequence {name!r}: {path} holds {extra} but meta.json says ground_truth is false"
        )
    if "images" in arrays and not camera:
        raise DatasetError(f"sequence {name!r}: {path} holds images but meta.json says camera "
                           "is false")  # fmt: skip
    n = entry["frames"]
    for k in [k for k in PER_FRAME if k in expected] + (["depth"] if "depth" in arrays else []):
        if arrays[k].ndim == 0 or len(arrays[k]) != n:
            raise DatasetError(
                f"sequence {name!r}: {k} has shape {arrays[k].shape}, meta says {n} frames"
            )
    for k in expected:
        dtype = ARRAYS[k]
        if arrays[k].dtype != dtype:
            raise DatasetError(
                f"sequence {name!r}: {k} has dtype {arrays[k].dtype}, expected {np.dtype(dtype)}"
            )
        trailing = arrays[k].shape[0 if k == "angles" else 1 :]
        want = SHAPES[k]
        if len(trailing) != len(want) or any(
            w not in (-1, t) for w, t in zip(want, trailing, strict=True)
        ):
            lead = () if k == "angles" else ("frames",)
            form = ", ".join([*lead, *("*" if w < 0 else str(w) for w in want)])
            raise DatasetError(
                f"sequence {name!r}: {k} has shape {arrays[k].shape}; expected ({form})"
            )
    if arrays["scans"].shape[1] != len(arrays["angles"]):
        raise DatasetError(
            f"sequence {name!r}: scans have {arrays['scans'].shape[1]} beams but angles has "
            f"{len(arrays['angles'])}"
        )
    problem = _value_problem(arrays, manifolds)
    if problem:
        raise DatasetError(f"sequence {name!r}: {path}: {problem}")
    return Sequence(
        name=name,
        world=entry["world"],
        depth=arrays.get("depth"),
        images=arrays.get("images"),
        **{k: arrays[k] for k in expected if k != "images"},
    )


def load_dataset(directory: str | os.PathLike, verify: bool = True) -> Dataset:
    """Load a complete dataset; refuse one that is partial, truncated or of another schema.

    Parameters
    ----------
    verify : bool
        Check each file's SHA-256 against ``meta.json`` (catches truncation; ~0.1 s per 100 MB).
    """
    directory = Path(directory)
    meta = read_meta(directory)
    if not meta.get("complete", False):
        raise DatasetError(
            f"{directory} is an incomplete collection ({len(meta.get('sequences', {}))} sequences "
            "done): rerun the same `topomap collect` command to resume it"
        )
    ground_truth = bool(meta.get("ground_truth", True))
    manifolds = len(meta["manifolds"]) if "manifolds" in meta else None
    seqs = {
        name: load_sequence(
            directory, name, entry, verify, ground_truth, manifolds, meta.get("camera", True)
        )
        for name, entry in meta["sequences"].items()
    }
    return Dataset(directory, meta, seqs)
