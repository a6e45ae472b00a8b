r"""Read 2-D laser logs in the Carmen format (``FLASER`` and ``ROBOTLASER1`` lines).

Carmen logs are text, one message per line, optionally gzip-compressed; public laser datasets
(e.g. Radish) come in it. Two messages carry a scan with its pose:

- ``FLASER n r_1 ... r_n x y theta odom_x odom_y odom_theta ipc_timestamp ipc_hostname
  logger_timestamp``: ``n`` ranges spread evenly over 180 degrees from -90 to +90 degrees
  around the heading, the laser pose ``(x, y, theta)`` and the odometry pose.
- ``ROBOTLASER1 laser_type start_angle field_of_view angular_resolution maximum_range accuracy
  remission_mode n r_1 ... r_n m e_1 ... e_m laser_x laser_y laser_theta robot_x robot_y
  robot_theta tv rv forward_safety_dist side_safety_dist turn_axis timestamp hostname
  logger_timestamp``: the beam geometry and the maximum range travel with the scan; the pose
  is the laser's.

A log holds one of the two (``message="auto"`` takes ``ROBOTLASER1`` when present, since it
states its own geometry, else ``FLASER``). Every other message (``PARAM``, ``ODOM``, ``#``
comments, ...) carries no scan and is skipped, except ``PARAM robot_front_laser_max``, the
sensor's maximum range for ``FLASER`` logs. Every line that is read is checked; a bad one stops
the whole read with a ``CarmenError`` naming the file and the line, so nothing is half-loaded.
Values no robot records are refused with the bound they break (`common.bounds`: positions
within 10^6 m, finite ranges within 10^4 m, beam geometry within a full turn); readings above the
sensor's maximum range are kept as no-returns (Carmen logs e.g. 81.91 m for a beam without a
return of a laser whose range is 50 m). Lines are the file's ``\n``-separated lines, so the
line numbers are those of ``sed -n`` and editors, whatever other control characters (a lone
``\r`` included) a line holds.

The log must be a regular file (or a link to one): a named pipe, a device or a folder is refused
before it is opened for reading, since reading it could block or never end. At most
``MAX_LOG_BYTES`` (1 GiB) of text are read, counted after decompression; a larger log is
refused rather than exhausting memory.
"""

from __future__ import annotations

import gzip
import io
import math
import os
import warnings
import zlib
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from common.bounds import (
    FULL_TURN,
    MAX_RANGE,
    MAX_TIME,
    angle_problem,
    pose_problem,
    range_problem,
)
from common.fileio import NotARegularFile, open_regular
from common.validation import is_real

__all__ = ["CarmenError", "CarmenLog", "read_carmen"]

MESSAGES = ("FLASER", "ROBOTLASER1")
_FLASER_TAIL = 9  # x y theta odom_x odom_y odom_theta ipc_timestamp hostname logger_timestamp
_ROBOTLASER_HEAD = 7  # laser_type start_angle fov resolution max_range accuracy remission_mode
_ROBOTLASER_TAIL = 14  # laser pose, robot pose, tv rv, 3 safety fields, timestamp host logger
_MAX_RANGE_PARAM = "robot_front_laser_max"
# the largest log read, in bytes of text after decompression: the largest public Radish logs
# are a few hundred MB; a bomb of a few KB that expands to GiB stops here, not in MemoryError
MAX_LOG_BYTES = 1 << 30


class CarmenError(ValueError):
    """A Carmen log that cannot be read; the message names the file and the line."""


@dataclass(frozen=True)
class CarmenLog:
    r"""The scans of a Carmen log with their poses.

    Attributes
    ----------
    path : Path
    message : str
        ``"FLASER"`` or ``"ROBOTLASER1"``: the lines the scans come from.
    ranges : ndarray of shape (N, B)
        Ranges in metres; readings ``>= max_range`` are no-returns (Carmen logs the maximum).
    angles : ndarray of shape (B,)
        Beam angles in the laser frame (radians, counter-clockwise from the x axis).
    max_range : float
        The sensor's maximum range: ``ROBOTLASER1``'s own field, else ``PARAM
        robot_front_laser_max``, else the largest reading of the log (the value Carmen writes
        for a beam without a return), unless given to ``read_carmen``.
    poses : ndarray of shape (N, 3)
        Laser poses ``(x, y, theta)`` in the log's world frame (corrected poses in a corrected
        log).
    odometry : ndarray of shape (N, 3) or None
        The odometry pose of each ``FLASER`` scan (``ROBOTLASER1`` has none).
    timestamps : ndarray of shape (N,)
        ``ipc_timestamp`` (``FLASER``) or ``timestamp`` (``ROBOTLASER1``) in seconds.
    line_numbers : ndarray of shape (N,)
        1-based line of each scan in the file.

    Parameters
    ----------
    path, message, ranges, angles, max_range, poses, odometry, timestamps, line_numbers
        The attributes above, as [`read_carmen`][sim.readers.carmen.read_carmen] reads them from a
        log.

    Examples
    --------
    >>> from pathlib import Path
    >>> from sim.readers import read_carmen
    >>> _ = Path("two-scans.log").write_text(
    ...     "FLASER 3 1.0 2.0 80.0 0.0 0.0 0.0 0.0 0.0 0.0 1.0 host 1.0\n"
    ...     "FLASER 3 1.5 2.5 80.0 0.5 0.0 0.1 0.5 0.0 0.1 2.0 host 2.0\n")
    >>> log = read_carmen("two-scans.log")
    >>> len(log), log.message, log.max_range, log.poses[1].tolist()
    (2, 'FLASER', 80.0, [0.5, 0.0, 0.1])

    See Also
    --------
    sim.readers.read_carmen : Reads a log.
    mapping.grouping.ObservationGraphPartitioner : Groups its scans.
    """

    path: Path
    message: str
    ranges: np.ndarray
    angles: np.ndarray
    max_range: float
    poses: np.ndarray
    odometry: np.ndarray | None
    timestamps: np.ndarray
    line_numbers: np.ndarray

    def __len__(self) -> int:
        """Return the number of scans."""
        return int(self.ranges.shape[0])


def _read_text(path: Path) -> str:
    """At most ``MAX_LOG_BYTES + 1`` characters of the log, decompressed when it is gzip."""
    with open_regular(path) as raw:
        gz = raw.read(2) == b"\x1f\x8b"
        raw.seek(0)
        stream = gzip.GzipFile(fileobj=raw, mode="rb") if gz else raw
        # newline="": a lone \r stays inside its line, as it does for sed and editors
        with io.TextIOWrapper(stream, encoding="ascii", newline="") as text:
            return text.read(MAX_LOG_BYTES + 1)


def _read_lines(path: Path) -> list[str]:
    try:
        text = _read_text(path)
    except NotARegularFile as err:
        raise CarmenError(f"{err}; a Carmen log must be a regular file") from None
    except (OSError, EOFError, UnicodeDecodeError, zlib.error) as err:  # gzip: all four
        raise CarmenError(f"{path}: cannot read as a (gzip) text Carmen log: {err}") from err
    if len(text) > MAX_LOG_BYTES:  # ascii: one character is one byte
        raise CarmenError(
            f"{path}: more than MAX_LOG_BYTES = {MAX_LOG_BYTES} bytes of text (after "
            "decompression); split the log, or raise sim.readers.carmen.MAX_LOG_BYTES"
        )
    # not splitlines(): it also splits at form feeds, vertical tabs and \x1c-\x1e, which would
    # shift every later line number away from the file's own
    lines = text.split("\n")
    return lines[:-1] if lines and lines[-1] == "" else lines


def _numbers(path: Path, line_no: int, fields: list[str], what: str) -> np.ndarray:
    try:
        values = np.array([float(v) for v in fields])
    except ValueError:
        bad = next(v for v in fields if not _is_float(v))
        raise CarmenError(f"{path}, line {line_no}: non-numeric {what} field {bad!r}") from None
    if not np.isfinite(values).all():
        raise CarmenError(f"{path}, line {line_no}: {what} contains NaN or infinity")
    return values


def _is_float(text: str) -> bool:
    try:
        float(text)
    except ValueError:
        return False
    return True


def _count(path: Path, line_no: int, fields: list[str], at: int, what: str) -> int:
    if at >= len(fields):
        raise CarmenError(f"{path}, line {line_no}: truncated line, no {what} count")
    text = fields[at]
    # no line holds 10^10 values, and int() of over 4300 digits raises a ValueError of its own
    if not (text.isdigit() and len(text) <= 10):
        raise CarmenError(
            f"{path}, line {line_no}: {what} count must be an integer of at most 10 digits, "
            f"got {text[:20]!r}{'...' if len(text) > 20 else ''}"
        )
    return int(text)


def _beam_count(path: Path, line_no: int, fields: list[str], at: int, message: str) -> int:
    """Read the range count at ``fields[at]``, at least 1: a scan without beams is refused."""
    n = _count(path, line_no, fields, at, "range")
    if n < 1:
        raise CarmenError(f"{path}, line {line_no}: {message} with {n} ranges; need at least 1")
    return n


def _parse_flaser(path: Path, line_no: int, fields: list[str]) -> dict:
    n = _beam_count(path, line_no, fields, 1, "FLASER")
    expected = 2 + n + _FLASER_TAIL
    if len(fields) != expected:
        raise CarmenError(
            f"{path}, line {line_no}: FLASER with {n} ranges needs {expected} fields, got "
            f"{len(fields)} (truncated line, or a range count that does not match its ranges)"
        )
    ranges = _numbers(path, line_no, fields[2 : 2 + n], "range")
    tail = _numbers(path, line_no, fields[2 + n : 2 + n + 7], "pose")
    scan = {"ranges": ranges, "pose": tail[:3], "odometry": tail[3:6], "time": tail[6]}
    return _checked(path, line_no, scan)


def _checked(path: Path, line_no: int, scan: dict) -> dict:
    """``scan`` once its ranges, poses and time are within `common.bounds`."""
    problem = (
        range_problem(scan["ranges"])
        or pose_problem(scan["pose"], "laser pose")
        or (scan["odometry"] is not None and pose_problem(scan["odometry"], "odometry pose"))
    )
    if not problem and abs(scan["time"]) > MAX_TIME:
        problem = f"timestamp {float(scan['time'])!r} is beyond the bound of {MAX_TIME:g} s"
    if problem:
        raise CarmenError(f"{path}, line {line_no}: {problem}")
    return scan


def _check_geometry(path: Path, line_no: int, n: int, head: np.ndarray) -> None:
    """Check a ``ROBOTLASER1`` header's beam geometry and maximum range.

    Start angle within a full turn, angular resolution in (0, 2 pi] (0 allowed for one beam),
    field of view in (0, 2 pi] (0 allowed for one beam) and maximum range in (0, MAX_RANGE].
    """
    start, fov, resolution, max_range = (float(v) for v in head[1:5])
    if n > 1 and resolution == 0:
        raise CarmenError(
            f"{path}, line {line_no}: ROBOTLASER1 angular_resolution is 0, so all {n} beams "
            "would point the same way; need a non-zero angle between beams"
        )
    low = "[0" if n == 1 else "(0"
    for name, value in (("angular_resolution", resolution), ("field_of_view", fov)):
        if not (0 <= value <= FULL_TURN and (n == 1 or value > 0)):
            raise CarmenError(
                f"{path}, line {line_no}: ROBOTLASER1 {name} {value!r} rad is outside {low}, 2 pi]"
            )
    problem = angle_problem(start, "ROBOTLASER1 start_angle")
    if problem:
        raise CarmenError(f"{path}, line {line_no}: {problem}")
    if not 0 < max_range <= MAX_RANGE:
        raise CarmenError(
            f"{path}, line {line_no}: ROBOTLASER1 maximum_range {max_range!r} m is outside "
            f"(0, {MAX_RANGE:g}]"
        )


def _parse_robotlaser(path: Path, line_no: int, fields: list[str]) -> dict:
    n = _beam_count(path, line_no, fields, 1 + _ROBOTLASER_HEAD, "ROBOTLASER1")
    at = 2 + _ROBOTLASER_HEAD + n  # the remission count
    m = _count(path, line_no, fields, at, "remission")
    expected = at + 1 + m + _ROBOTLASER_TAIL
    if len(fields) != expected:
        raise CarmenError(
            f"{path}, line {line_no}: ROBOTLASER1 with {n} ranges and {m} remissions needs "
            f"{expected} fields, got {len(fields)} (truncated line, or a count that does not "
            "match its values)"
        )
    head = _numbers(path, line_no, fields[1 : 1 + _ROBOTLASER_HEAD], "header")
    _check_geometry(path, line_no, n, head)
    ranges = _numbers(path, line_no, fields[2 + _ROBOTLASER_HEAD : at], "range")
    tail = _numbers(path, line_no, fields[at + 1 + m : at + 1 + m + 12], "pose")
    scan = {
        "ranges": ranges,
        "geometry": head[1:5],  # start angle, field of view, resolution, max range
        "pose": tail[:3],
        "odometry": None,
        "time": tail[11],
    }
    return _checked(path, line_no, scan)


def read_carmen(
    path: str | os.PathLike,
    *,
    message: str = "auto",
    max_range: float | None = None,
) -> CarmenLog:
    """Read the laser scans and poses of a Carmen log (plain or gzip text).

    Parameters
    ----------
    path : path
    message : {"auto", "FLASER", "ROBOTLASER1"}, default "auto"
        Which lines hold the scans; ``"auto"``: ``ROBOTLASER1`` when the log has any, else
        ``FLASER``.
    max_range : float, optional
        The sensor's maximum range in metres, overriding what the log says (see
        ``CarmenLog.max_range``).

    Returns
    -------
    CarmenLog

    Raises
    ------
    CarmenError
        Naming the file and the line: a path that is no regular file (a named pipe, a device,
        a folder, a link to one), more than ``MAX_LOG_BYTES`` of text, a damaged file (gzip
        or text), no scans, a truncated
        line, a non-numeric field, NaN or infinite ranges, poses or times, negative ranges,
        values beyond `common.bounds` (positions beyond 10^6 m, ranges beyond 10^4 m), a
        count that does not match its values, a scan without ranges, a ``ROBOTLASER1`` angular
        resolution or field of view outside (0, 2 pi], scans with different numbers of beams
        or different beam geometry.

    Warns
    -----
    UserWarning
        When the timestamps go backwards somewhere (the scans are kept in file order).
    ValueError
        If ``message`` is unknown or ``max_range`` is not a positive finite number.
    """
    path = Path(path)
    if message not in ("auto", *MESSAGES):
        raise ValueError(f"message must be 'auto' or one of {MESSAGES}, got {message!r}")
    if max_range is not None and not (is_real(max_range) and 0 < max_range <= MAX_RANGE):
        raise ValueError(
            f"max_range must be None or a positive finite number of metres (at most "
            f"{MAX_RANGE:g}), got {max_range!r}"
        )
    lines = _read_lines(path)
    firsts = [line.split(maxsplit=1)[0] if line.strip() else "" for line in lines]
    if message == "auto":
        message = "ROBOTLASER1" if "ROBOTLASER1" in firsts else "FLASER"
    parse = _parse_flaser if message == "FLASER" else _parse_robotlaser
    scans, numbers, param_max = [], [], None
    for k, (first, line) in enumerate(zip(firsts, lines, strict=True), start=1):
        if first == message:
            scans.append(parse(path, k, line.split()))
            numbers.append(k)
        elif first == "PARAM":
            fields = line.split()
            if len(fields) >= 3 and fields[1] == _MAX_RANGE_PARAM and _is_float(fields[2]):
                param_max = float(fields[2])
                if not 0 < param_max <= MAX_RANGE:
                    raise CarmenError(
                        f"{path}, line {k}: {_MAX_RANGE_PARAM} {param_max!r} m is outside "
                        f"(0, {MAX_RANGE:g}]"
                    )
    if not scans:
        raise CarmenError(f"{path}: no {message} lines, so no scans (lines read: {len(lines)})")
    n_beams = len(scans[0]["ranges"])
    for scan, k in zip(scans, numbers, strict=True):
        if len(scan["ranges"]) != n_beams:
            raise CarmenError(
                f"{path}, line {k}: {len(scan['ranges'])} ranges, but line {numbers[0]} has "
                f"{n_beams}; one log must keep one beam layout"
            )
    times = np.array([s["time"] for s in scans])
    back = np.flatnonzero(np.diff(times) < 0)
    if back.size:
        warnings.warn(
            f"{path}, line {numbers[back[0] + 1]}: the timestamp goes backwards ({back.size} "
            "times in the log); the scans are kept in the order of the file",
            stacklevel=2,
        )
    ranges = np.stack([s["ranges"] for s in scans])
    if message == "FLASER":
        # README of the Radish logs: n beams spread evenly from -90 to +90 degrees
        angles = np.linspace(-np.pi / 2, np.pi / 2, n_beams)
        log_max = param_max if param_max is not None else float(ranges.max())
        odometry = np.stack([s["odometry"] for s in scans])
    else:
        geometry = np.stack([s["geometry"] for s in scans])
        changed = np.flatnonzero(np.any(geometry != geometry[0], axis=1))
        if changed.size:
            raise CarmenError(
                f"{path}, line {numbers[changed[0]]}: beam geometry (start angle, field of "
                f"view, resolution, max range) differs from line {numbers[0]}"
            )
        start, _, resolution, log_max = geometry[0]
        angles = start + resolution * np.arange(n_beams)
        odometry = None
    max_range = float(log_max if max_range is None else max_range)
    if not (math.isfinite(max_range) and 0 < max_range <= MAX_RANGE):
        raise CarmenError(
            f"{path}: maximum range {max_range!r} is not a distance in (0, {MAX_RANGE:g}] m"
        )
    return CarmenLog(
        path=path,
        message=message,
        ranges=ranges,
        angles=angles,
        max_range=max_range,
        poses=np.stack([s["pose"] for s in scans]),
        odometry=odometry,
        timestamps=times,
        line_numbers=np.array(numbers),
    )
