"""Loop closure on a real log: odometry simulated from the corrected poses,
the pose graph must bring the trajectory closer to them than the drifting odometry."""

import gzip
import json

from experiments.grouping import loop_closure as elc


def test_loop_closure_on_a_slice_of_a_real_log(tmp_path, aces_log):
    lines = gzip.open(aces_log, "rt").read().splitlines()
    scans = [line for line in lines if line.startswith("FLASER")][:150]
    log = tmp_path / "aces-slice.log"
    log.write_text("\n".join(scans) + "\n")
    result = elc.evaluate_carmen([log], tmp_path / "out")
    assert json.loads((tmp_path / "out" / elc.JSON_FILE).read_text()) == result
    rows = result["aces-slice"]
    assert rows["corrected (truth)"]["ate"]["rmse_m"] == 0.0
    odometry = rows["odometry"]["ate"]["rmse_m"]
    assert odometry > 0.1  # the simulated odometry drifts
    assert rows["odometry+icp+loop closure"]["ate"]["rmse_m"] < odometry
    assert 0 <= rows["loops"] <= rows["candidates"]
    text = elc.format_report(result)
    assert "aces-slice | odometry+icp+loop closure" in text and "| -- |" in text
