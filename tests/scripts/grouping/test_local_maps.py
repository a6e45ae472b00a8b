"""The local-map evaluation on a slice of a real log: every method scored,
the JSON written, the report printed."""

import json

import numpy as np

from scripts.grouping import local_maps as elm


def test_local_maps_on_a_slice_of_a_real_log(tmp_path, aces_slice_log):
    ((tag, (scans, truth, odometry, groups)),) = elm.carmen_cases([aces_slice_log]).items()
    n = 90
    cases = {tag: (scans[:n], truth[:n], odometry[:n], groups[:n])}
    result = elm.evaluate_cases(cases, tmp_path, progress=False)
    assert json.loads((tmp_path / elm.JSON_FILE).read_text()) == json.loads(json.dumps(result))
    for variant in ("true", "odometry+icp"):
        case = result["cases"][tag][variant]
        assert case["train"] + case["held_out"] == n
        assert {"grouping", "every n scans", "every d m", "global"} <= set(case)
        assert case["global"]["submaps"] == 1
        assert case["grouping"]["submaps"] >= 1
        for method in ("grouping", "every n scans", "every d m", "global"):
            rate = case[method]["localisation"]
            assert rate["held_out"] == case["held_out"] and 0 <= rate["rate"] <= 1
            low, high = rate["rate_ci95"]
            assert low <= rate["rate"] <= high
    text = elm.format_report(result)
    assert tag in text and "global" in text


def test_simulated_odometry_drifts_and_is_seeded():
    poses = np.stack([np.linspace(0, 10, 50), np.zeros(50), np.zeros(50)], axis=1)
    a, b = elm.simulated_odometry(poses, seed=1), elm.simulated_odometry(poses, seed=1)
    np.testing.assert_array_equal(a, b)
    assert not np.allclose(a, poses)
