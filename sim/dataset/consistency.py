"""The checks across a dataset's sequences, and between them and ``meta.json``'s settings.

Written once, applied by [`sim.dataset.load_dataset`][sim.dataset.loading.load_dataset] after
each sequence passed its own.

Every sequence of a dataset comes from one robot setup, so all keep the same laser (the same
beam angles, hence the same beam count) and the same image size, and agree with what the
settings record (``settings.laser.beams``, ``settings.laser.fov`` for the span of the beam
angles, ``settings.camera.width`` and ``height``, ``settings.worlds``) where they record it;
otherwise ``Dataset.concat`` would stack arrays of different forms and the methods would mix
beams that point different ways.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from common.bounds import FULL_TURN
from common.validation import is_real
from sim.dataset.schema import META_FILE, DatasetError

__all__ = ["ANGLE_TOLERANCE", "SPAN_TOLERANCE", "check_consistency"]

# two sequences' beams are the same beams when their angles differ by at most this (rad): the
# float32 rounding of one angle is ~1e-7 rad, a real difference of set-up at least ~1e-3 rad
ANGLE_TOLERANCE = 1e-5
# the span of the beam angles matches settings.laser.fov within this (rad): float32 angles of
# a few radians are rounded by ~1e-6 rad, a field of view off by one beam of 1 degree by 1.7e-2
SPAN_TOLERANCE = 1e-4


def _setting(meta: dict, sensor: str, key: str):
    """``meta["settings"][sensor][key]`` when it is a whole number, else None (not recorded)."""
    value = ((meta.get("settings") or {}).get(sensor) or {}).get(key)
    return value if isinstance(value, int) and not isinstance(value, bool) else None


def _fov(directory: Path, meta: dict) -> float | None:
    """Return the size of ``meta["settings"]["laser"]["fov"]`` when it is a real number.

    It is refused beyond a full turn; None when not recorded. The ROS bag importer records
    the span of the beam angles, last minus first: negative for a scan of decreasing angles, 0
    for one beam.
    """
    value = ((meta.get("settings") or {}).get("laser") or {}).get("fov")
    if not is_real(value):
        return None
    if not abs(value) <= FULL_TURN + SPAN_TOLERANCE:  # NaN too; a 400-digit int compares
        raise DatasetError(
            f"{directory / META_FILE}: settings.laser.fov must be a field of "
            f"view of at most 2 pi rad, got {repr(value)[:40]}"
        )
    return abs(float(value))


def _span_problem(angles: np.ndarray, fov: float) -> str | None:
    """Say why beam ``angles`` cannot be those of a laser of field of view ``fov``, or None.

    They can when the angles span ``fov`` (the first beam at one edge, the last at the other,
    as a ROS scan's angle_min and angle_max and a collection's laser have them), or
    ``fov (n - 1) / n`` for a full turn (the last beam one step short of the first).
    """
    n = len(angles)
    if n < 2:
        return None
    span = abs(float(angles[-1]) - float(angles[0]))
    if min(abs(span - fov), abs(span - fov * (n - 1) / n)) <= SPAN_TOLERANCE:
        return None
    return f"beam angles span {span:.6g} rad, but {META_FILE}'s settings.laser.fov is {fov:.6g} rad"


def check_consistency(directory: Path, meta: dict, sequences: dict) -> None:
    """Raise an error when the sequences disagree with each other or with the settings.

    A [`DatasetError`][sim.dataset.schema.DatasetError] names the dataset's folder, the
    sequence and its file when a sequence's beams, angles, image size or world disagrees with
    the first sequence's or with the settings of ``meta``.

    Parameters
    ----------
    directory : Path
        The dataset's folder.
    meta : dict
        The parsed ``meta.json``.
    sequences : dict of str to Sequence
        The loaded [`Sequence`][sim.dataset.model.Sequence] objects by name.
    """
    where = {
        name: f"{directory}: sequence {name!r} ({meta['sequences'][name]['file']})"
        for name in sequences
    }
    beams, fov = _setting(meta, "laser", "beams"), _fov(directory, meta)
    width, height = _setting(meta, "camera", "width"), _setting(meta, "camera", "height")
    worlds = (meta.get("settings") or {}).get("worlds")
    first = next(iter(sequences.values()), None)
    for name, s in sequences.items():
        if s.angles is not None:
            if beams is not None and len(s.angles) != beams:
                raise DatasetError(
                    f"{where[name]}: {len(s.angles)} beams, but {META_FILE}'s "
                    f"settings.laser.beams is {beams}"
                )
            problem = None if fov is None else _span_problem(s.angles, fov)
            if problem:
                raise DatasetError(f"{where[name]}: {problem}")
            if len(s.angles) != len(first.angles):
                raise DatasetError(
                    f"{where[name]}: {len(s.angles)} beams, but sequence {first.name!r} has "
                    f"{len(first.angles)}; the sequences of one dataset keep one laser"
                )
            gap = float(np.max(np.abs(s.angles.astype(float) - first.angles), initial=0.0))
            if not gap <= ANGLE_TOLERANCE:
                raise DatasetError(
                    f"{where[name]}: beam angles differ from sequence {first.name!r}'s by up to "
                    f"{gap:.3g} rad (more than {ANGLE_TOLERANCE:g}); the sequences of one "
                    "dataset keep one laser"
                )
        if s.images is not None:
            h, w = s.images.shape[1:3]
            if None not in (width, height) and (w, h) != (width, height):
                raise DatasetError(
                    f"{where[name]}: images of {w}x{h}, but {META_FILE}'s "
                    f"settings.camera is {width}x{height}"
                )
            if s.images.shape[1:] != first.images.shape[1:]:
                raise DatasetError(
                    f"{where[name]}: images of shape {s.images.shape[1:]}, but sequence "
                    f"{first.name!r} has {first.images.shape[1:]}; the sequences of one "
                    "dataset keep one camera"
                )
        if isinstance(worlds, list) and s.world not in worlds:
            raise DatasetError(
                f"{where[name]}: world {s.world!r} is not among {META_FILE}'s "
                f"settings.worlds {worlds}"
            )
