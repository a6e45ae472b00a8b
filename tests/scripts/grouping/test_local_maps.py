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
    # 10 m straight ahead; the dataset's noise (sim.odometry.OdometryConfig's defaults):
    # forward 0.02 m / sqrt(m) and heading 0.015 rad / sqrt(m), so after 10 m the forward error
    # has a standard deviation of 0.063 m and the heading 0.047 rad
    poses = np.stack([np.linspace(0, 10, 50), np.zeros(50), np.zeros(50)], axis=1)
    runs = np.stack([elm.simulated_odometry(poses, seed=s) for s in range(200)])
    np.testing.assert_array_equal(runs[:, 0], np.broadcast_to(poses[0], (200, 3)))  # starts true
    np.testing.assert_array_equal(elm.simulated_odometry(poses, seed=1), runs[1])  # seeded
    assert not np.allclose(runs[1], runs[2])  # two seeds, two drifts
    error = runs[:, -1] - poses[-1]
    # measured over these 200 seeds: 0.064 m and 0.047 rad; a wrong or no noise falls outside
    assert 0.05 < error[:, 0].std() < 0.08 and 0.035 < error[:, 2].std() < 0.06
    assert abs(error[:, 0].mean()) < 0.02 and abs(error[:, 2].mean()) < 0.015  # no bias
    # the heading error turns into sideways drift that grows along the route
    side = np.abs(runs[:, :, 1]).mean(axis=0)
    assert side[10] < side[25] < side[-1] and 0.1 < side[-1] < 0.4
