"""The report's opening summary on fake stage results: one line per task, the worst world's
number with its interval, the target the code states (or none), and the page's table of it."""

import pytest

from scripts import report
from scripts.manifold import FEATURES
from servo.task import POLICIES, SUCCESS_TARGETS, TIERS
from servo.task.stats import wilson_interval

HSV = FEATURES["hsv"][0]


def _protocol_row(condition, method, mean, lo, hi, features="hsv", dev=0.03):
    return {
        "condition": condition,
        "features": features,
        "method": method,
        "dev_error": dev,
        "seeds": list(range(1, 11)),
        "errors": [mean] * 10,
        "summary": {"mean": mean, "lo": lo, "hi": hi, "n": 10},
    }


SEEDS = {
    "source": "docs/results/manifold-protocol",
    "rows": [
        _protocol_row("interleaved", "scikit-learn kNN (k=10)", 0.098, 0.076, 0.12),
        _protocol_row("hard", "ours", 0.36, 0.33, 0.39),
        _protocol_row("interleaved", "ours", 0.088, 0.055, 0.127),
        _protocol_row("interleaved", "ours", 0.5, 0.4, 0.6, features="raw"),
    ],
}
MANIFOLD = {
    "real": [
        {"features": "raw pixels", "method": "ours", "test_error": 0.3},
        {"features": HSV, "method": "best-sigma NCut", "test_error": 0.2},
        {"features": HSV, "method": "ours", "test_error": 0.029},
    ]
}


def _score(purity, max_groups, meets):
    return {"purity": purity, "max_groups_per_manifold": max_groups, "meets_targets": meets}


def _grouping(hallway, lawn):
    return {
        "settings": {
            "targets": {"purity_min": 0.9, "max_groups_per_manifold": 3},
            "shown": "odometry+icp",
        },
        "default": {
            "hallway": {"frames": 450, "odometry": _score(0.5, 9, False), "odometry+icp": hallway},
            "lawn": {"frames": 450, "odometry": _score(0.99, 1, True), "odometry+icp": lawn},
        },
    }


def _servo(world, policy, tier, successes, episodes=20, randomize=False):
    return {
        "world": world,
        "policy": policy,
        "tier": tier,
        "split": "test",
        "randomize": randomize,
        "episodes": episodes,
        "successes": successes,
        "success_rate": successes / episodes,
        "success_ci95": list(wilson_interval(successes, episodes)),
    }


def test_the_manifold_line_is_the_protocols_headline_cell_with_its_interval():
    (line,) = report.summarise_run({"seeds": SEEDS, "manifold": MANIFOLD})
    assert line["task"].startswith("manifold clustering")
    assert (line["value"], line["interval"]) == (0.088, [0.055, 0.127])
    assert line["interval_kind"] == "bootstrap 95%" and "10 fresh dataset seeds" in line["measure"]
    assert line["target"] is None and line["meets"] is None  # the code states none
    assert "dev seed 0: 0.030" in line["detail"] and "test error 0.029" in line["detail"]


def test_without_the_protocol_the_manifold_line_is_this_runs_seed_without_interval():
    for seeds in ({"source": None, "rows": []}, None):
        (line,) = report.summarise_run({"seeds": seeds, "manifold": MANIFOLD})
        assert (line["value"], line["interval"], line["target"]) == (0.029, None, None)
        assert "one dataset seed" in line["measure"]


def test_the_grouping_line_is_the_worst_world_against_the_targets_of_every_world():
    (line,) = report.summarise_run(
        {"grouping": _grouping(_score(0.97, 2, True), _score(0.93, 3, True))}
    )
    assert line["value"] == 0.93 and line["meets"] is True and line["interval"] is None
    assert line["target"] == "purity >= 0.9 and <= 3 groups per manifold, in every world"
    assert "hallway: purity 0.970, at most 2 groups per manifold (meets)" in line["detail"]
    # purity met everywhere, but one world splits a manifold into too many groups
    (line,) = report.summarise_run(
        {"grouping": _grouping(_score(0.97, 4, False), _score(0.93, 3, True))}
    )
    assert line["value"] == 0.93 and line["meets"] is False
    assert "hallway: purity 0.970, at most 4 groups per manifold (misses)" in line["detail"]


def test_an_unscored_grouping_is_said_not_scored():
    unscored = {"purity": None, "max_groups_per_manifold": None, "meets_targets": None}
    (line,) = report.summarise_run({"grouping": _grouping(unscored, unscored)})
    assert line["value"] is None and line["meets"] is None
    assert "not scored" in line["detail"]
    assert "<td>not scored</td>" in report.section_summary([line])


def test_a_servo_line_per_policy_and_start_condition_with_the_worst_world():
    results = [
        _servo("hallway", "servo", "anywhere", 19),
        _servo("lawn", "servo", "anywhere", 20),
        _servo("hallway", "signal", "anywhere", 18),
        _servo("lawn", "signal", "anywhere", 11),
        _servo("hallway", "signal", "anywhere", 16, randomize=True),
        _servo("hallway", "oracle", "anywhere", 20),
        _servo("hallway", "servo", "view", 20),
    ]
    lines = report.summarise_run({"servo": {"results": results, "videos": {}}})
    by_task = {line["task"]: line for line in lines}
    assert list(by_task) == [
        "servo: ManifoldServo (laser and images), starts anywhere",
        "servo: SignalServo (camera only), starts anywhere",
        "servo: SignalServo (camera only), starts anywhere + randomize",
        "servo: oracle (true pose; the upper bound), starts anywhere",
        "servo: ManifoldServo (laser and images), starts view",
    ]
    servo, signal, randomized, oracle, view = lines
    # ManifoldServo's target from anywhere is 95 % in every world: 19/20 meets it
    assert (servo["value"], servo["target"], servo["meets"]) == (
        0.95,
        ">= 0.95 in every world",
        True,
    )
    assert servo["interval"] == list(wilson_interval(19, 20))
    assert servo["measure"] == "success rate on the test split, lowest world (hallway; 20 episodes)"
    assert "lawn: 20/20 = 1.00" in servo["detail"]
    # SignalServo: 80 % from anywhere, decided by the lawn's 11/20
    assert (signal["value"], signal["meets"]) == (0.55, False) and "lawn" in signal["measure"]
    assert randomized["target"] == ">= 0.75 in every world"
    assert (randomized["value"], randomized["meets"]) == (0.8, True)
    for line in (oracle, view):  # no stated target: none is made up
        assert line["target"] is None and line["meets"] is None


def test_the_servo_targets_name_real_policies_and_tiers():
    assert SUCCESS_TARGETS
    for (policy, tier, randomize), goal in SUCCESS_TARGETS.items():
        assert policy in POLICIES and tier in TIERS and isinstance(randomize, bool)
        assert 0 < goal <= 1


def test_stages_that_did_not_run_give_no_line():
    assert report.summarise_run({}) == []
    assert report.summarise_run({"worlds": {}, "dataset": {}}) == []


@pytest.fixture
def page_lines():
    return report.summarise_run(
        {
            "seeds": SEEDS,
            "manifold": MANIFOLD,
            "grouping": _grouping(_score(0.97, 2, True), _score(0.93, 4, False)),
            "servo": {"results": [_servo("lawn", "signal", "anywhere", 11)], "videos": {}},
        }
    )


def test_the_summary_table_shows_each_line_with_interval_target_and_verdict(page_lines):
    html = report.section_summary(page_lines)
    assert html.startswith('<section id="summary">\n<h2>Summary</h2>')
    rows = html.split("<tbody>")[1].split("</tr>")
    manifold, grouping, signal = rows[:3]
    assert "<td>0.088 [0.055, 0.127] (bootstrap 95%)</td><td>no target</td><td>&ndash;</td>" in (
        manifold
    )
    assert "<td>0.930</td><td>purity &gt;= 0.9 and &lt;= 3 groups" in grouping
    assert "<td>no</td>" in grouping
    lo, hi = wilson_interval(11, 20)
    assert (
        f"<td>0.550 [{lo:.3f}, {hi:.3f}] (Wilson 95%)</td><td>&gt;= 0.80 in every world</td>"
        "<td>no</td>" in signal
    )


def test_the_summary_opens_the_page(page_lines):
    page = report.build_html(
        "t",
        [report.section("worlds", "The worlds"), report.section("servo", "Servo")],
        summary=report.section_summary(page_lines),
    )
    top = page.index('<section id="summary">')
    assert top < page.index('<a href="#worlds">') < page.index('<section id="worlds">')
    assert page.index("<h1>") < top
