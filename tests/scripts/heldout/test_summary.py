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
    diff = s["manifold"]["ours_minus_sklearn"]
    assert diff["mean"] == pytest.approx(0.0) and diff["lo"] <= diff["hi"]
    assert s["grouping"]["purity"]["canonical"] == pytest.approx(0.95)
    assert s["grouping"]["purity"]["held_out"]["mean"] == pytest.approx(0.85)
    assert s["worlds"] == ["hallway:11000", "hallway:11001"]
    text = format_summary(summarise(cells, frames=150))
    assert "| hallway | clustering error | ours | 5.0% | 20.0% [" in text
    assert "+15.0 points" in text


def test_the_plan_is_the_canonical_world_then_held_out_test_worlds():
    cells = plan(["lawn"], 3, [0, 1])
    worlds = [w for w, _ in cells]
    first = held_out_worlds("lawn", 1)[0]  # lawn:11000 repeats a train world's structure
    assert first == "lawn:11001"
    assert worlds[:2] == ["lawn", "lawn"] and worlds[2:4] == [first, first]
    assert len(cells) == 8 and {s for _, s in cells} == {0, 1}
