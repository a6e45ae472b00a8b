"""Videos a browser plays inline.

RGB frames are written as H.264 in MP4, atomically, and the codec of an MP4 is read back from
its sample entries.

Browsers play H.264 (``avc1``) in MP4 but refuse MPEG-4 part 2 (``mp4v``, OpenCV's default
MP4 codec): Chromium reports "no supported streams". The encoder is the ffmpeg binary that the
``imageio-ffmpeg`` wheel ships (libx264 included), so a plain ``pip install`` is enough.
"""

from __future__ import annotations

import contextlib
import os
import struct
import subprocess
import tempfile
from collections.abc import Iterable
from pathlib import Path

import numpy as np

from common.fileio import atomic_path

__all__ = ["BROWSER_CODECS", "mp4_codecs", "write_mp4"]

BROWSER_CODECS = ("avc1",)  # what write_mp4 writes; the report's checker accepts only these
# H.264 in 4:2:0 needs an even width and height: an odd one gets a black row or column.
_EVEN = "pad=ceil(iw/2)*2:ceil(ih/2)*2"
# Boxes that hold the path moov/trak/mdia/minf/stbl/stsd to each track's sample entries.
_CONTAINERS = {b"moov", b"trak", b"mdia", b"minf", b"stbl"}


def write_mp4(path: str | os.PathLike, frames: Iterable[np.ndarray], fps: float = 10) -> Path:
    """Write RGB frames as an H.264 MP4 that browsers play inline; atomically.

    Parameters
    ----------
    path : path-like
        The ``.mp4`` to write; its folder is created. Nothing is left there if writing fails.
    frames : iterable of (H, W, 3) uint8 arrays
        At least one, all of one size; an odd width or height is padded by one black column
        or row.
    fps : float, default 10
        Frames per second.

    Returns
    -------
    Path
        ``path``.

    Raises
    ------
    ValueError
        No frames, a frame that is not (H, W, 3) uint8, or frames of different sizes.
    RuntimeError
        ffmpeg failed; the message holds what it said.

    Notes
    -----
    libx264 at constant quality (CRF 23), pixel format ``yuv420p`` (the one every browser
    decodes) and the index moved to the front (``+faststart``), so that playback starts before
    the whole file has loaded.
    """
    import imageio_ffmpeg  # only the writers of videos need ffmpeg

    frames = iter(frames)
    first = next(frames, None)
    if first is None:
        raise ValueError("frames is empty: a video needs at least one frame")
    first = _check_frame(first, None)
    h, w = first.shape[:2]
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    with atomic_path(path) as tmp, tempfile.TemporaryFile() as log:
        # the temporary name ends in .tmp: the container is named, not guessed from it
        cmd = [
            imageio_ffmpeg.get_ffmpeg_exe(),
            "-v",
            "error",
            "-y",
            "-f",
            "rawvideo",
            "-pix_fmt",
            "rgb24",
            "-s",
            f"{w}x{h}",
            "-r",
            f"{fps:g}",
            "-i",
            "-",
            "-an",
            "-vf",
            _EVEN,
            "-c:v",
            "libx264",
            "-crf",
            "23",
            "-pix_fmt",
            "yuv420p",
            "-movflags",
            "+faststart",
            "-f",
            "mp4",
            str(tmp),
        ]
        proc = subprocess.Popen(cmd, stdin=subprocess.PIPE, stdout=subprocess.DEVNULL, stderr=log)
        try:
            proc.stdin.write(first.tobytes())
            for frame in frames:
                proc.stdin.write(_check_frame(frame, first.shape).tobytes())
        except BrokenPipeError:  # ffmpeg quit early: its own message says why, below
            pass
        except BaseException:
            proc.kill()
            proc.wait()
            raise
        finally:
            with contextlib.suppress(BrokenPipeError):
                proc.stdin.close()
        if proc.wait() != 0:
            log.seek(0)
            said = log.read().decode(errors="replace").strip()
            raise RuntimeError(f"ffmpeg could not write {path} (exit {proc.returncode}): {said}")
    return path


def _check_frame(frame, shape: tuple | None) -> np.ndarray:
    frame = np.ascontiguousarray(frame)
    if frame.dtype != np.uint8 or frame.ndim != 3 or frame.shape[2] != 3:
        raise ValueError(
            f"frames must be (H, W, 3) uint8 RGB arrays, got {frame.dtype} {frame.shape}"
        )
    if shape is not None and frame.shape != shape:
        raise ValueError(f"frames must all have one size: {shape}, then {frame.shape}")
    return frame


def mp4_codecs(path: str | os.PathLike) -> list[str]:
    """Read the codec of each track of the MP4 ``path``.

    Each is the four-character code of the track's first sample entry (``avc1``: H.264;
    ``mp4v``: MPEG-4 part 2; ``vp09``: VP9; ...). Reads the box headers only
    (moov/trak/mdia/minf/stbl/stsd), so it costs a few small reads whatever the file's size.
    Raises ``ValueError`` for a file that is not an MP4 with a sample description.

    Parameters
    ----------
    path : path-like
        The MP4 file.

    Returns
    -------
    list of str
        One four-character code per track.
    """
    path = Path(path)
    with path.open("rb") as f:
        codecs = _sample_entries(f, 0, path.stat().st_size)
    if not codecs:
        raise ValueError(f"{path}: no MP4 sample description (moov/.../stsd) found")
    return codecs


def _sample_entries(f, start: int, end: int) -> list[str]:
    """Read the codecs of the sample descriptions inside the boxes from ``start`` to ``end``."""
    out = []
    at = start
    while at + 8 <= end:
        f.seek(at)
        size, kind = struct.unpack(">I4s", f.read(8))
        header = 8
        if size == 1 and at + 16 <= end:  # a 64-bit size follows the type
            (size,) = struct.unpack(">Q", f.read(8))
            header = 16
        elif size == 0:  # the box runs to the end of its parent
            size = end - at
        if size < header or at + size > end:
            raise ValueError(f"not an MP4: a box {kind!r} of {size} bytes at byte {at}")
        if kind in _CONTAINERS:
            out += _sample_entries(f, at + header, at + size)
        elif kind == b"stsd":
            # version and flags (4 bytes), the entry count (4), then the first entry's size
            # (4) and its type: the codec
            f.seek(at + header + 8)
            entry = f.read(8)
            if len(entry) == 8:
                out.append(entry[4:].decode("latin-1"))
        at += size
    return out
