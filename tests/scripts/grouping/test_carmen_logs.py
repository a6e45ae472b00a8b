"""The grouping on a real Carmen log, end to end through the command line."""

import gzip
import json

import pytest

from scripts.cli import main as cli_main
from scripts.grouping.carmen_logs import JSON_FILE, evaluate_carmen
from sim.readers.carmen import CarmenError

SCANS = 60


@pytest.fixture(scope="module")
def aces_slice(tmp_path_factory, aces_slice_log):
    """The first 60 scans of the shipped slice of the ACES log (every third scan), with its
    header, as a plain-text log of its own."""
    with gzip.open(aces_slice_log, "rt") as f:
        lines = [line for line in f if not line.startswith("FLASER")][:20]
        f.seek(0)
        lines += [line for line in f if line.startswith("FLASER")][:SCANS]
    path = tmp_path_factory.mktemp("carmen") / "aces-slice.log"
    path.write_text("".join(lines))
    return path


def test_cli_groups_a_real_log(aces_slice, tmp_path, capsys):
    out = tmp_path / "out"
    args = ["group-eval", "--carmen", str(aces_slice), "--out", str(out), "--quiet", "--json"]
    assert cli_main(args) == 0
    printed = json.loads(capsys.readouterr().out)
    on_disk = json.loads((out / JSON_FILE).read_text())
    entry = on_disk["logs"]["aces-slice"]
    assert printed["logs"]["aces-slice"]["given"]["groups"] == entry["given"]["groups"]
    assert entry["scans"] == SCANS and entry["beams"] == 180 and entry["max_range_m"] == 50.0
    for variant in ("given", "given+icp"):
        s = entry[variant]
        assert 1 <= s["groups"] <= SCANS
        assert s["group_size"]["min"] <= s["group_size"]["median"] <= s["group_size"]["max"]
    # given poses are used as they are without ICP
    assert entry["given"]["max_pose_change_m"] == 0.0
    assert len(on_disk["figures"]) == 4
    for name in on_disk["figures"]:
        assert (out / name).read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"


def test_a_bad_log_stops_before_anything_is_written(aces_slice, tmp_path):
    lines = aces_slice.read_text().splitlines()
    k = next(i for i, line in enumerate(lines) if line.startswith("FLASER")) + 5
    lines[k] = lines[k].replace("FLASER 180 ", "FLASER 180 nan ", 1).rsplit(" ", 1)[0]
    bad = tmp_path / "bad.log"
    bad.write_text("\n".join(lines))
    out = tmp_path / "out"
    with pytest.raises(CarmenError, match=f"bad.log, line {k + 1}: range contains NaN"):
        evaluate_carmen([aces_slice, bad], out, progress=False)
    assert not out.exists()
    with pytest.raises(ValueError, match="paths is empty"):
        evaluate_carmen([], out)
