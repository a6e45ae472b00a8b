from scripts.grouping.evaluate import format_report
from scripts.grouping.tables import NO_LABELS, comparison_table, grouping_table
from scripts.report.sections import section_grouping


def _score(**over):
    s = {
        "frames": 450,
        "groups": 7,
        "purity": 0.9512,
        "ari": 0.5291,
        "groups_per_manifold": {"main": 2, "left": 1},
        "max_groups_touching": 5,
        "max_groups_per_manifold": 2,
        "max_drift_m": 0.234,
        "seconds": 1.5,
        "meets_targets": True,
    }
    return {**s, **over}


RESULT = {
    "default": {"hallway": {"true": _score(), "figures": ["a.png"]}},
    "loop": {"lawn": {"odometry": _score(meets_targets=False, purity=0.8)}},
    "compare": {"hallway": {"partition/scans": _score()}},
    "figures": [],
}


def test_one_table_for_the_command_line_and_the_report():
    table = grouping_table(RESULT)
    assert [r["case"] for r in table.rows] == ["hallway", "lawn-loop"]
    md = format_report(RESULT)
    assert "| hallway | true | 450 | 7 | 0.951 | +0.529 | 2 / 1 | 5 | 0.23 | 1.50 | met |" in md
    assert "| lawn-loop | odometry | 450 | 7 | 0.800 |" in md and md.count("missed") == 1
    assert "| hallway | partition/scans | 7 | 0.951 | +0.529 | 2 | 1.50 |" in md
    page = section_grouping(RESULT)
    assert table.to_html() in page and comparison_table(RESULT).to_html() in page
    assert "<th>groups per manifold (majority)</th>" in page


def test_unscored_groups_read_as_missing_with_a_note():
    bare = _score(
        purity=None,
        ari=None,
        groups_per_manifold={},
        max_groups_touching=None,
        max_drift_m=None,
        meets_targets=None,
    )
    result = {"default": {"x": {"given": bare}}, "loop": {}, "compare": {}, "ground_truth": False}
    md = format_report(result)
    assert "| x | given | 450 | 7 | -- | -- | -- | -- | -- | 1.50 | -- |" in md
    assert NO_LABELS in md
