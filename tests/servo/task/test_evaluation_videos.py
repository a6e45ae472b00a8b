"""The episode videos of the closed-loop evaluation, written by the code path the report uses:
H.264 a browser plays, one frame per step."""

import subprocess

from common.video import mp4_codecs


def test_evaluate_writes_episode_videos_browsers_play(servo_maps, tmp_path):
    import imageio_ffmpeg

    from servo.task import evaluate

    result = evaluate(
        "hallway",
        1,
        0,
        policy="oracle",
        servo_map=servo_maps["hallway"],
        out=tmp_path,
        videos=1,
        max_steps=4,
        progress=False,
    )
    path = tmp_path / "hallway-oracle-episode0.mp4"
    assert mp4_codecs(path) == ["avc1"]
    # ffmpeg decodes every frame: one per step of the episode
    out = subprocess.run(
        [imageio_ffmpeg.get_ffmpeg_exe(), "-hide_banner", "-i", str(path), "-f", "null", "-"],
        capture_output=True,
        text=True,
    )
    assert out.returncode == 0, out.stderr
    frames = int(out.stderr.rsplit("frame=", 1)[1].split()[0])
    assert frames == result["episodes_detail"][0]["steps"]
    assert sorted(p.suffix for p in tmp_path.iterdir()) == [".mp4", ".png"]
