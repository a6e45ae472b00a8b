"""The report's episode videos: shown in the page with ``<video controls>``, found by the page's
own file check, and refused by ``check_report`` when a browser would not play them."""

import numpy as np

from common.video import write_mp4
from scripts import report
from scripts.check_report import main, problems

VIDEOS = {"hallway/servo": ["servo/hallway-servo-episode0.mp4"], "lawn/servo": ["servo/l.mp4"]}


def test_the_servo_section_plays_each_video_in_the_page():
    html = report.section_servo([], VIDEOS)
    for src in ("servo/hallway-servo-episode0.mp4", "servo/l.mp4"):
        assert f'<video src="{src}" controls preload="metadata"></video>' in html
        assert f'<a href="{src}">' in html  # and a link to the file
    assert "hallway/servo" in html and "lawn/servo" in html
    assert report.referenced_files(report.build_html("t", [html])) == [
        "servo/hallway-servo-episode0.mp4",
        "servo/l.mp4",
    ]
    assert "<video" not in report.section_servo([], {})


def _page_with_video(root, write):
    page = report.build_html("t", [report.section("servo", "S", report.video("v.mp4", "clip"))])
    write(root / "v.mp4")
    (root / report.INDEX).write_text(page)
    return root / report.INDEX


def test_check_report_accepts_the_h264_the_evaluation_writes(tmp_path):
    frames = [np.full((24, 40, 3), 40 * i, np.uint8) for i in range(4)]
    index = _page_with_video(tmp_path, lambda p: write_mp4(p, frames))
    assert problems(index) == []
    assert main([str(index)]) == 0


def test_check_report_refuses_a_video_browsers_do_not_play(tmp_path, capsys):
    import cv2

    def mpeg4_part2(path):  # OpenCV's "mp4v": Chromium finds "no supported streams" in it
        writer = cv2.VideoWriter(str(path), cv2.VideoWriter_fourcc(*"mp4v"), 10, (40, 24))
        for i in range(4):
            writer.write(np.full((24, 40, 3), 40 * i, np.uint8))
        writer.release()

    index = _page_with_video(tmp_path, mpeg4_part2)
    assert problems(index) == ["v.mp4: codec mp4v; browsers play avc1 (H.264)"]
    assert main([str(index)]) == 1
    assert "v.mp4: codec mp4v" in capsys.readouterr().err
    (tmp_path / "v.mp4").write_bytes(b"mp4")
    assert problems(index)[0].startswith("v.mp4: not a readable MP4")


def test_a_video_path_and_caption_are_escaped_once():
    html = report.video("servo/a&b.mp4", "x<y")
    assert 'src="servo/a&amp;b.mp4"' in html and ">a&amp;b.mp4</a>" in html and "x&lt;y" in html
    assert report.referenced_files(html) == ["servo/a&b.mp4"]
