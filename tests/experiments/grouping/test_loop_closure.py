"""Loop closure on a real log: odometry simulated from the corrected poses,
the pose graph must bring the trajectory closer to them than the drifting odometry."""

import gzip
import json

from experiments.grouping import loop_closure as elc


def test_loop_closure_on_a_slice_of_a_real_log(tmp_path, aces_slice_log):
    # every third scan of the ACES log: the whole route, so its loops are in it (the first 150
    # scans alone hold none, and the loop closure would have nothing to close)
    lines = gzip.open(aces_slice_log, "rt").read().splitlines()
    scans = [line for line in lines if line.startswith("FLASER")]
    log = tmp_path / "aces-slice.log"
    log.write_text("\n".join(scans) + "\n")
    result = elc.evaluate_carmen([log], tmp_path / "out")
    assert json.loads((tmp_path / "out" / elc.JSON_FILE).read_text()) == result
    rows = result["aces-slice"]
    assert rows["corrected (truth)"]["ate"]["rmse_m"] == 0.0
    odometry = rows["odometry"]["ate"]["rmse_m"]
    assert odometry > 0.1  # the simulated odometry drifts
    icp = rows["odometry+icp"]["ate"]["rmse_m"]
    assert icp < odometry
    # loops found and closed, and closing them pulls the trajectory toward the truth
    # (measured on this slice: 2 loops of 9 candidates, 2.20 m -> 1.62 m)
    assert 1 <= rows["loops"] <= rows["candidates"]
    assert rows["odometry+icp+loop closure"]["ate"]["rmse_m"] < 0.9 * icp
    text = elc.format_report(result)
    assert "aces-slice | odometry+icp+loop closure" in text and "| -- |" in text
