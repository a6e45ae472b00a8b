from scripts.report.sections import section_servo
from scripts.servo_tables import pair_table, summary_table

PAIR = {
    "episodes": 20,
    "success_rate": 0.85,
    "success_ci95": [0.64, 0.95],
    "spl": 0.7,
    "final_distance": 0.31,
    "collisions": 1.5,
}
RESULT = {
    "world": "lawn",
    "policy": "signal",
    "tier": "anywhere",
    "split": "test",
    "randomize": True,
    **PAIR,
    "final_heading_error_deg": 4.0,
    "steps": None,
    "act_ms": 2.5,
    "reasons": {"success": 17, "timeout": 3},
    "per_pair": {"lawn -> lawn-left": PAIR},
}


def test_the_cli_and_the_report_show_one_servo_table():
    md = summary_table([RESULT]).to_markdown()
    assert (
        "| lawn | signal | anywhere/test/randomize | 20 | 0.85 | [0.64, 0.95] | 0.70 | 0.31 "
        "| 4.0 | -- | 1.5 | 2.50 | success: 17, timeout: 3 |"
    ) in md
    pairs = pair_table([RESULT])
    assert [r["pair"] for r in pairs.rows] == ["lawn -> lawn-left"]
    page = section_servo([{**RESULT, "plot": None}], {})
    assert summary_table([RESULT]).to_html() in page and pairs.to_html() in page


def test_results_without_a_protocol_have_no_condition():
    plain = {k: v for k, v in RESULT.items() if k not in ("tier", "split", "randomize")}
    table = summary_table([plain])
    assert table.rows[0]["condition"] is None
    assert "starts / split" not in table.to_markdown()  # a column no row fills is left out
    assert "starts / split" in summary_table([plain, RESULT]).to_markdown()
