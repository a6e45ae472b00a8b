"""Sequence files written and read.

An ``.npz`` is written atomically with its SHA-256, read without pickle, and checked against
its ``meta.json`` entry and `common.bounds`.
"""

from __future__ import annotations

import hashlib
import os
import zipfile
from pathlib import Path

import numpy as np

from common import bounds
from common.fileio import atomic_path
from common.npz import UnreadableNpz, read_arrays
from sim.dataset.consistency import check_consistency
from sim.dataset.model import Dataset, Sequence
from sim.dataset.schema import (
    ARRAYS,
    GROUND_TRUTH,
    META_FILE,
    OPTIONAL,
    PER_FRAME,
    SENSORS,
    SHAPES,
    SPECIAL,
    DatasetError,
    read_meta,
)


def write_sequence(path: Path, arrays: dict[str, np.ndarray], compresslevel: int = 1) -> str:
    """Write arrays as an ``.npz``, atomically; return its SHA-256.

    Deflate level 1 (the default) gives most of the size win at a fraction of the time.

    Parameters
    ----------
    path : Path
        The ``.npz`` to write.
    arrays : dict of str to ndarray
        The arrays by name; each is stored as ``name.npy``, without pickle.
    compresslevel : int, default 1
        Deflate level.

    Returns
    -------
    str
        The file's SHA-256, hex.
    """
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
    """Compute the SHA-256 of a file's bytes, read in 4 MiB chunks.

    Parameters
    ----------
    path : Path
        The file.

    Returns
    -------
    str
        The digest, hex.
    """
    h = hashlib.sha256()
    with open(path, "rb") as f:
        for chunk in iter(lambda: f.read(1 << 22), b""):
            h.update(chunk)
    return h.hexdigest()


def read_npz(
    path: Path, sha256: str | None, context: str = "", error: type[Exception] = DatasetError
) -> dict[str, np.ndarray]:
    """Read the arrays of an ``.npz`` without pickle, checking its SHA-256 first when given.

    The file is one as [`write_sequence`][sim.dataset.loading.write_sequence] writes it; a
    missing, modified or unreadable file raises ``error`` starting with ``context``.

    Parameters
    ----------
    path : Path
        The ``.npz`` file.
    sha256 : str or None
        Its expected SHA-256, hex; None skips the check.
    context : str, default ""
        Start of the error message.
    error : type of Exception, default DatasetError
        The error raised.

    Returns
    -------
    dict of str to ndarray
        The arrays by name.
    """
    if not path.is_file():  # a pipe or a device there would block or never end a read
        raise error(f"{context}{path} is {'missing' if not path.exists() else SPECIAL}")
    if sha256 is not None and file_sha256(path) != sha256:
        raise error(f"{context}{path} is truncated or modified (checksum mismatch)")
    try:
        return read_arrays(path)
    except UnreadableNpz as err:
        raise error(f"{context}{path} cannot be read ({err})") from err


def _value_problem(arrays: dict[str, np.ndarray], manifolds: int | None) -> str | None:
    """Say what is wrong with the values of a sequence's arrays (`common.bounds`), or None.

    ``manifolds``: how many there are (labels must lie in ``[-1, manifolds)``), None: any.
    """
    image_shape = arrays["images"].shape[1:] if "images" in arrays else (1, 1, 3)
    beams = len(arrays["angles"]) if "angles" in arrays else 1
    if 0 in image_shape[:2] or beams == 0:
        return f"images of shape {image_shape} and scans of {beams} beams: neither may be empty"
    labels = arrays.get("labels")
    if labels is not None and manifolds is not None and len(labels):
        low, high = int(labels.min()), int(labels.max())
        if low < -1 or high >= manifolds:
            return (
                f"labels from {low} to {high}, but meta.json has {manifolds} manifolds: a label "
                f"is -1 (on none) or in 0..{manifolds - 1}"
            )
    checks = [
        ("scans", bounds.range_problem),
        ("angles", bounds.angle_problem),
        ("odometry", bounds.pose_problem),
        ("poses", bounds.pose_problem),
        ("commands", bounds.command_problem),
        ("times", bounds.time_problem),
        ("depth", bounds.range_problem),
    ]
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
    laser: bool = True,
) -> Sequence:
    """Load one sequence's file, checked against its ``meta.json`` entry.

    Parameters
    ----------
    directory : Path
        The dataset's folder.
    name : str
        The sequence's name.
    entry : dict
        Its ``meta.json`` entry (``file``, ``world``, ``frames``, ``sha256``).
    verify : bool, default True
        Check the file's SHA-256 against the entry.
    ground_truth : bool, default True
        Whether ``poses`` and ``labels`` must be there (True) or must not (False).
    manifolds : int, optional
        How many manifolds its labels may name; None: not checked.
    camera : bool, default True
        Whether ``images`` must be there (True) or must not (False).
    laser : bool, default True
        The same of ``scans`` and ``angles``.

    Returns
    -------
    Sequence
        The sequence's arrays.
    """
    path = Path(directory) / entry["file"]
    arrays = read_npz(path, entry["sha256"] if verify else None, f"sequence {name!r}: ")

    def fail(problem: str):
        raise DatasetError(f"{path}: sequence {name!r}: {problem}")

    absent = (
        (() if ground_truth else GROUND_TRUTH)
        + (() if camera else SENSORS["camera"])
        + (() if laser else SENSORS["laser"])
    )
    absent += tuple(k for k in OPTIONAL if k not in arrays)
    expected = [k for k in ARRAYS if k not in absent]
    missing = [k for k in expected if k not in arrays]
    if missing:
        fail(f"arrays {missing} missing")
    extra = [k for k in GROUND_TRUTH if k in arrays and not ground_truth]
    if extra:
        fail(f"holds {extra} but meta.json says ground_truth is false")
    for sensor, on in (("camera", camera), ("laser", laser)):
        held = [k for k in SENSORS[sensor] if k in arrays]
        if held and not on:
            fail(f"holds {held} but meta.json says {sensor} is false")
    n = entry["frames"]
    for k in [k for k in (*PER_FRAME, *OPTIONAL) if k in expected]:
        if arrays[k].ndim == 0 or len(arrays[k]) != n:
            fail(f"{k} has shape {arrays[k].shape}, meta says {n} frames")
    for k in expected:
        dtype = ARRAYS[k]
        if arrays[k].dtype != dtype:
            fail(f"{k} has dtype {arrays[k].dtype}, expected {np.dtype(dtype)}")
        trailing = arrays[k].shape[0 if k == "angles" else 1 :]
        want = SHAPES[k]
        if len(trailing) != len(want) or any(
            w not in (-1, t) for w, t in zip(want, trailing, strict=True)
        ):
            lead = () if k == "angles" else ("frames",)
            form = ", ".join([*lead, *("*" if w < 0 else str(w) for w in want)])
            fail(f"{k} has shape {arrays[k].shape}; expected ({form})")
    if laser and arrays["scans"].shape[1] != len(arrays["angles"]):
        fail(f"scans have {arrays['scans'].shape[1]} beams but angles has {len(arrays['angles'])}")
    if camera and "depth" in arrays and arrays["depth"].shape[1:] != arrays["images"].shape[1:3]:
        fail(
            f"depth has shape {arrays['depth'].shape}; expected (frames, "
            f"{', '.join(map(str, arrays['images'].shape[1:3]))}), the images' size"
        )
    problem = _value_problem(arrays, manifolds)
    if problem:
        fail(problem)
    return Sequence(
        name=name,
        world=entry["world"],
        depth=arrays.get("depth"),
        images=arrays.get("images"),
        scans=arrays.get("scans"),
        angles=arrays.get("angles"),
        **{k: arrays[k] for k in expected if k not in ("images", "scans", "angles", "depth")},
    )


def load_dataset(directory: str | os.PathLike, verify: bool = True) -> Dataset:
    """Load a complete dataset; refuse one that is partial, truncated or of another schema.

    Parameters
    ----------
    directory : path-like
        The dataset's folder.
    verify : bool, default True
        Check each file's SHA-256 against ``meta.json`` (catches truncation; ~0.1 s per 100 MB).

    Returns
    -------
    Dataset
        The dataset's ``meta.json`` and sequences.
    """
    directory = Path(directory)
    meta = read_meta(directory)
    if not meta.get("complete", False):
        raise DatasetError(
            f"{directory} is an incomplete collection ({len(meta.get('sequences', {}))} sequences "
            "done): rerun the same `topomap collect` command to resume it"
        )
    ground_truth = bool(meta.get("ground_truth", True))
    if ground_truth and meta["sequences"] and "manifolds" not in meta:
        # without the names, labels could not be checked, and nothing could name them
        raise DatasetError(
            f"{directory / META_FILE}: the sequences have labels (ground_truth) but there is "
            "no 'manifolds' list of the names they index"
        )
    manifolds = len(meta["manifolds"]) if "manifolds" in meta else None
    seqs = {
        name: load_sequence(
            directory,
            name,
            entry,
            verify,
            ground_truth,
            manifolds,
            meta.get("camera", True),
            meta.get("laser", True),
        )
        for name, entry in meta["sequences"].items()
    }
    check_consistency(directory, meta, seqs)
    return Dataset(directory, meta, seqs)
