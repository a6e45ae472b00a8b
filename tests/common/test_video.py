"""Videos a browser plays: what ``write_mp4`` writes is H.264 in MP4 (as ffmpeg itself reads
it back), even-sized, indexed at the front, and written atomically; ``mp4_codecs`` tells it
from the MPEG-4 part 2 that OpenCV writes."""

import struct
import subprocess

import numpy as np
import pytest

from common.video import BROWSER_CODECS, mp4_codecs, write_mp4


def _frames(n=6, h=61, w=83):
    rng = np.random.default_rng(0)
    return [rng.integers(0, 256, (h, w, 3), dtype=np.uint8) for _ in range(n)]


def _ffmpeg_says(path) -> str:
    """The video stream line of ``ffmpeg -i path`` (ffmpeg reading the file itself)."""
    import imageio_ffmpeg

    err = subprocess.run(
        [imageio_ffmpeg.get_ffmpeg_exe(), "-hide_banner", "-i", str(path)],
        capture_output=True,
        text=True,
    ).stderr
    return next(line for line in err.splitlines() if "Video:" in line)


def _top_level_boxes(path) -> list[bytes]:
    data, at, kinds = path.read_bytes(), 0, []
    while at + 8 <= len(data):
        size, kind = struct.unpack(">I4s", data[at : at + 8])
        kinds.append(kind)
        at += size
    return kinds


def test_write_mp4_writes_h264_that_browsers_play(tmp_path):
    path = write_mp4(tmp_path / "a" / "episode.mp4", _frames(), fps=10)
    assert path == tmp_path / "a" / "episode.mp4"
    assert mp4_codecs(path) == ["avc1"] and set(mp4_codecs(path)) <= set(BROWSER_CODECS)
    said = _ffmpeg_says(path)
    # H.264 in 4:2:0, the odd 83x61 padded to even sizes
    assert "Video: h264" in said and "yuv420p" in said and "84x62" in said, said
    boxes = _top_level_boxes(path)
    assert boxes.index(b"moov") < boxes.index(b"mdat")  # +faststart: plays while loading
    assert sorted(p.name for p in path.parent.iterdir()) == ["episode.mp4"]


def test_mp4_codecs_tells_the_mpeg4_part2_that_browsers_refuse(tmp_path):
    import cv2

    frames = _frames(h=60, w=84)
    writer = cv2.VideoWriter(
        str(tmp_path / "old.mp4"), cv2.VideoWriter_fourcc(*"mp4v"), 10, (84, 60)
    )
    for f in frames:
        writer.write(f)
    writer.release()
    assert mp4_codecs(tmp_path / "old.mp4") == ["mp4v"]
    assert "Video: mpeg4" in _ffmpeg_says(tmp_path / "old.mp4")


@pytest.mark.parametrize("data", [b"", b"not a video at all", b"\x00\x00\x00\x01moov"])
def test_mp4_codecs_refuses_what_is_not_an_mp4(tmp_path, data):
    (tmp_path / "x.mp4").write_bytes(data)
    with pytest.raises(ValueError, match="x.mp4|not an MP4"):
        mp4_codecs(tmp_path / "x.mp4")


def test_a_failed_write_leaves_the_old_video_and_no_temporary_file(tmp_path):
    path = write_mp4(tmp_path / "v.mp4", _frames(2))
    before = path.read_bytes()
    frames = _frames(3)
    frames[2] = frames[2][:, :-1]  # a frame of another size, after two were sent
    with pytest.raises(ValueError, match="one size"):
        write_mp4(path, frames)
    assert path.read_bytes() == before
    assert sorted(p.name for p in tmp_path.iterdir()) == ["v.mp4"]


@pytest.mark.parametrize(
    ("frames", "match"),
    [
        ([], "at least one frame"),
        ([np.zeros((8, 8, 3), np.float32)], "uint8"),
        ([np.zeros((8, 8), np.uint8)], r"\(H, W, 3\)"),
    ],
)
def test_write_mp4_refuses_what_is_not_rgb_frames(tmp_path, frames, match):
    with pytest.raises(ValueError, match=match):
        write_mp4(tmp_path / "v.mp4", frames)
    assert not list(tmp_path.iterdir())


def test_ffmpegs_own_refusal_is_raised_with_its_message(tmp_path):
    with pytest.raises(RuntimeError, match="ffmpeg could not write"):
        write_mp4(tmp_path / "v.mp4", _frames(2), fps=-1)
    assert not list(tmp_path.iterdir())
