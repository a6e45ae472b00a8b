"""The held-out summary: canonical beside held-out worlds, the gap, the paired difference."""

import pytest

from scenes.families.splits import held_out_worlds
from scripts.heldout.evaluate import format_summary, plan, summarise
from scripts.manifold.methods import OURS, SKLEARN_DEFAULT


def _cell(world, family, ours, theirs, purity):
    rows = [{"method": OURS, "test_error": ours}, {"method": SKLEARN_DEFAULT, "test_error": theirs}]
    return {
        "world": world,
        "family": family,
        "tasks": {
            "manifold": {"rows": rows},
            "grouping": {"purity": purity, "max_groups_per_manifold": 2},
        },
    }


def test_summary_sets_held_out_worlds_beside_the_canonical_one():
    cells = [
        _cell("hallway", "hallway", 0.05, 0.10, 0.95),
        _cell("hallway:11000", "hallway", 0.10, 0.20, 0.90),
        _cell("hallway:11001", "hallway", 0.30, 0.20, 0.80),
    ]
    s = summarise(cells, frames=150)["families"]["hallway"]
    ours = s["manifold"][OURS]
    assert ours["canonical"] == pytest.approx(0.05)
    assert ours["held_out"]["mean"] == pytest.approx(0.20) and ours["held_out"]["n"] == 2
    assert ours["worlds_past_target"] == 1  # 30 % > 15 %
    diff = s["manifold"]["ours minus scikit-learn"]
    assert diff["mean"] == pytest.approx(0.0) and diff["lo"] <= diff["hi"]
    assert s["grouping"]["purity"]["canonical"] == pytest.approx(0.95)
    assert s["grouping"]["purity"]["held_out"]["mean"] == pytest.approx(0.85)
    assert s["worlds"] == ["hallway:11000", "hallway:11001"]
    text = format_summary(summarise(cells, frames=150))
    assert "| hallway | clustering error | ours, Q = 35 | 5.0% | 20.0% [" in text
    assert "+15.0 points" in text and "| ours, Q = 35 minus scikit-learn |" in text


def test_a_method_that_refused_a_world_is_counted_not_averaged():
    cells = [
        _cell("lawn:11001", "lawn", 0.10, 0.20, 0.9),
        _cell("lawn:11002", "lawn", 0.3, 0.1, 0.9),
    ]
    cells[1]["tasks"]["manifold"]["rows"][0]["test_error"] = None  # ours refused: K x Q > n
    ours = summarise(cells, frames=150)["families"]["lawn"]["manifold"][OURS]
    assert ours["held_out"]["n"] == 1 and ours["worlds_refused"] == 1
    assert (
        "ours minus scikit-learn"
        not in summarise(cells, frames=150)["families"]["lawn"]["manifold"]
    )


def test_the_plan_is_the_canonical_world_then_held_out_test_worlds():
    cells = plan(["lawn"], 3, [0, 1])
    worlds = [w for w, _ in cells]
    first = held_out_worlds("lawn", 1)[0]  # lawn:11000 repeats a train world's structure
    assert first == "lawn:11001"
    assert worlds[:2] == ["lawn", "lawn"] and worlds[2:4] == [first, first]
    assert len(cells) == 8 and {s for _, s in cells} == {0, 1}


def _servo_cell(world, records):
    family = world.split(":")[0]
    return {"world": world, "family": family, "tasks": {"servo": {"records": records}}}


def _ep(policy, tier, junctions, success):
    return {
        "policy": policy,
        "tier": tier,
        "junctions": junctions,
        "success": success,
        "spl": 0.8 * success,
    }


def test_servo_success_is_counted_per_controller_tier_and_junctions():
    cells = [
        _servo_cell("lawn", [_ep("servo", "view", 1, True), _ep("servo", "view", 1, True)]),
        _servo_cell("lawn:11001", [_ep("servo", "view", 1, True), _ep("servo", "view", 2, False)]),
        _servo_cell("lawn:11002", [_ep("servo", "view", 3, True), _ep("signal", "view", 1, False)]),
    ]
    s = summarise(cells, frames=150)["families"]["lawn"]["servo"]
    assert set(s) == {"servo/view", "signal/view"}
    held, canon = s["servo/view"]["held_out"], s["servo/view"]["canonical"]
    assert (held["successes"], held["n"]) == (2, 3) and (canon["successes"], canon["n"]) == (2, 2)
    assert held["lo"] < 2 / 3 < held["hi"] and held["spl"] == pytest.approx(1.6 / 3)
    by = s["servo/view"]["by_junctions"]
    assert by["1"]["n"] == 1 and by["2"]["successes"] == 0 and by["3"]["successes"] == 1
    assert s["servo/view"]["worlds"] == 2 and s["signal/view"]["canonical"] is None
    text = format_summary(summarise(cells, frames=150))
    assert "| lawn | servo | view | 2/2 (100% [" in text and "| -33 points |" in text
