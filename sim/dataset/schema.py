"""The dataset's schema.

The arrays of a sequence and their forms, ``meta.json`` and its checks, and the error every
dataset reader raises (the format: `sim.dataset`).
"""

from __future__ import annotations

import os
import re
from pathlib import Path

import numpy as np

from common.bounds import MAX_RANGE
from common.fileio import UnreadableJSON, read_json
from common.validation import is_real

SCHEMA_VERSION = 2
READABLE_VERSIONS = (1, 2)  # version 2 added "ground_truth" (false: no poses, no labels)
FORMAT_NAME = "topomap-dataset"
META_FILE = "meta.json"
ARRAYS = {  # name: dtype
    "images": np.uint8,
    "depth": np.float32,
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
    "depth": (-1, -1),
}
_FILE_NAME = re.compile(r"[A-Za-z0-9][A-Za-z0-9_.-]{0,200}\.npz\Z")  # the file system's limit
# A world (place) name: as a file name, and ':' for a generated world (``hallway:17``).
_WORLD = re.compile(r"[A-Za-z0-9][A-Za-z0-9_.:-]{0,200}\Z")
_SHA256 = re.compile(r"[0-9a-f]{64}\Z")
SPECIAL = "no regular file (a named pipe, a device, a folder, or a link to one)"
GROUND_TRUTH = ("poses", "labels")  # absent from a dataset without ground truth
OPTIONAL = ("depth",)  # present only when collected with it
SENSORS = {"camera": ("images",), "laser": ("scans", "angles")}  # absent without the sensor


class DatasetError(ValueError):
    """A dataset that is missing, truncated, inconsistent or from another schema version."""


class MissingSensorError(DatasetError):
    """A dataset recorded without the sensor a method needs.

    The grouping needs the laser's scans, the methods on images the camera's.

    Parameters
    ----------
    path : path-like
        The dataset's folder.
    sensor : {"camera", "laser"}
        The sensor missing.
    needed_by : str
        What needs the sensor, for the message.

    Attributes
    ----------
    path : Path
        The dataset's folder.
    sensor : str
        The sensor missing.
    """

    def __init__(self, path, sensor: str, needed_by: str):
        self.path, self.sensor = Path(path), sensor
        arrays = " or ".join(SENSORS[sensor])
        other = {"camera": "laser scans", "laser": "camera images"}[sensor]
        super().__init__(
            f"{path} has no {sensor} (no {arrays}: recorded or imported without one), and "
            f"{needed_by} needs the {sensor}'s {arrays}; the dataset holds {other} and "
            "odometry. Use a dataset with a " + sensor
        )


def read_meta(directory: str | os.PathLike) -> dict:
    """Read and check the ``meta.json`` of the dataset in ``directory`` (complete or not).

    Parameters
    ----------
    directory : path-like
        The dataset's folder.

    Returns
    -------
    dict
        The parsed ``meta.json``; a `DatasetError` says what is wrong with it.
    """
    path = Path(directory) / META_FILE
    if Path(directory).is_file():
        raise DatasetError(f"{directory} is a file, not a dataset folder")
    if not path.is_file():  # a pipe or a device there would block or never end a read
        what = "is missing" if not path.exists() else f"is {SPECIAL}"
        raise DatasetError(f"no dataset at {directory}: {META_FILE} {what}")
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
    files: dict[str, str] = {}
    for name, entry in sequences.items():
        check_entry(path, name, entry)
        other = files.setdefault(entry["file"], name)
        if other != name:  # its frames would be counted twice
            raise DatasetError(
                f"{path}: sequences {other!r} and {name!r} both name the file "
                f"{entry['file']!r}; each sequence has its own file"
            )
    _check_optional_keys(path, meta)
    return meta


def _check_optional_keys(path: Path, meta: dict) -> None:
    """Check the other keys the code reads, where present.

    These are ``settings`` (its ``laser`` and that one's ``max_range``, the laser's range, and
    its ``camera``), ``manifolds`` and ``complete``. They may be absent (a dataset of schema
    version 1, a collection just started).
    """
    settings = meta.get("settings", {})
    if not isinstance(settings, dict):
        raise DatasetError(f"{path}: 'settings' must be an object, got {settings!r}")
    laser = settings.get("laser", {})
    if laser is None and meta.get("laser") is False:  # no laser: no laser settings
        laser = {}
    if not isinstance(laser, dict):
        raise DatasetError(f"{path}: 'settings.laser' must be an object, got {laser!r}")
    camera = settings.get("camera")
    if camera is not None and not isinstance(camera, dict):
        raise DatasetError(
            f"{path}: 'settings.camera' must be an object or null, got {repr(camera)[:40]}"
        )
    r = laser.get("max_range", 1.0)
    if not (is_real(r) and 0 < r <= MAX_RANGE):  # an int of 400 digits compares exactly
        raise DatasetError(
            f"{path}: 'settings.laser.max_range' must be a number of metres in "
            f"(0, {MAX_RANGE:g}], got {repr(r)[:40]}"
        )
    manifolds = meta.get("manifolds", [])
    if not (isinstance(manifolds, list) and all(isinstance(m, str) for m in manifolds)):
        raise DatasetError(f"{path}: 'manifolds' must be a list of names, got {manifolds!r}")
    for sensor in SENSORS:
        if not isinstance(meta.get(sensor, True), bool):
            raise DatasetError(f"{path}: '{sensor}' must be true or false, got {meta[sensor]!r}")
    if not (meta.get("camera", True) or meta.get("laser", True)):
        raise DatasetError(
            f"{path}: 'camera' and 'laser' are both false; a dataset records "
            "at least one of the two sensors"
        )
    if not isinstance(meta.get("complete", False), bool):
        raise DatasetError(f"{path}: 'complete' must be true or false, got {meta['complete']!r}")


def check_entry(path: Path, name: str, entry) -> None:
    """Check a sequence entry of ``meta.json``; raise `DatasetError` if it is malformed.

    An entry holds a plain ``.npz`` file name inside the dataset folder (never a path
    elsewhere), a world name, a frame count and a SHA-256.

    Parameters
    ----------
    path : Path
        The ``meta.json`` file, for the message.
    name : str
        The sequence's name.
    entry : object
        The entry to check.
    """
    fields = ("file", "world", "frames", "sha256")
    if not isinstance(entry, dict) or any(k not in entry for k in fields):
        raise DatasetError(f"{path}: sequence {name!r} must have the fields {list(fields)}")
    file, world, frames, digest = (entry[k] for k in fields)
    if not (isinstance(file, str) and _FILE_NAME.match(file)):
        raise DatasetError(
            f"{path}: sequence {name!r} names the file {file!r}; expected a plain file name "
            "ending in .npz inside the dataset folder"
        )
    if not (isinstance(world, str) and _WORLD.match(world)):
        raise DatasetError(f"{path}: sequence {name!r} has the world {world!r}")
    if isinstance(frames, bool) or not isinstance(frames, int) or frames < 0:
        raise DatasetError(f"{path}: sequence {name!r} has {frames!r} frames; expected >= 0")
    if not (isinstance(digest, str) and _SHA256.match(digest)):
        raise DatasetError(f"{path}: sequence {name!r} has no valid sha256")
