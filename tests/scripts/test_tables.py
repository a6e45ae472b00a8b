import csv
import io
import json

import numpy as np
import pytest

from scripts.tables import Column, Table

COLUMNS = (
    Column("world", "world"),
    Column("rate", "success", ".2f"),
    Column("delta", "ARI", "+.3f"),
    Column("per", "per manifold"),
    Column("met", "met"),
    Column("n", "episodes", "d"),
)
ROWS = (
    {
        "world": "hall<way>",
        "rate": np.float64(0.5),
        "delta": -0.25,
        "per": [2, 1],
        "met": np.bool_(True),
        "n": np.int64(20),
        "extra": "not shown",
    },
    {
        "world": "lawn",
        "rate": None,
        "delta": float("nan"),
        "per": (),
        "met": False,
        "n": 3,
        "extra": 1,
    },
)


def table() -> Table:
    return Table.of(COLUMNS, ROWS, caption="Servo & co", notes=["2 cores"])


def test_markdown_formats_each_column_once():
    md = table().to_markdown().splitlines()
    assert md[0] == "**Servo & co**"
    assert md[2] == "| world | success | ARI | per manifold | met | episodes |"
    assert md[3] == "|---|---|---|---|---|---|"
    assert md[4] == "| hall<way> | 0.50 | -0.250 | 2 / 1 | yes | 20 |"
    assert md[5] == "| lawn | -- | -- |  | no | 3 |"
    assert md[-1] == "2 cores"


def test_html_escapes_text_and_marks_missing_values():
    page = table().to_html()
    assert "<caption>Servo &amp; co</caption>" in page
    assert "<td>hall&lt;way&gt;</td>" in page
    assert "<tr><td>lawn</td><td>&ndash;</td><td>&ndash;</td>" in page
    assert page.count("<tr>") == 3  # header + 2 rows
    assert "<p>2 cores</p>" in page


def test_csv_and_json_keep_raw_values_under_the_keys():
    rows = list(csv.reader(io.StringIO(table().to_csv())))
    assert rows[0] == ["world", "rate", "delta", "per", "met", "n"]
    assert rows[1][:3] == ["hall<way>", "0.5", "-0.25"]
    assert rows[2][1:3] == ["", ""]
    data = json.loads(table().render("json"))
    assert data["rows"][0] == {
        "world": "hall<way>",
        "rate": 0.5,
        "delta": -0.25,
        "per": [2, 1],
        "met": True,
        "n": 20,
    }
    assert data["rows"][1]["delta"] is None  # NaN is not JSON
    assert [c["header"] for c in data["columns"]][1] == "success"


def test_bad_tables_and_kinds_are_refused(tmp_path):
    with pytest.raises(ValueError, match="distinct keys"):
        Table.of([Column("a", "A"), Column("a", "B")], [])
    with pytest.raises(ValueError, match=r"rows\[1\] lacks the column key\(s\) \['n'\]"):
        Table.of(COLUMNS, [ROWS[0], {k: v for k, v in ROWS[1].items() if k != "n"}])
    with pytest.raises(ValueError, match="kind must be one of"):
        table().write(tmp_path / "t", kinds=("md", "xlsx"))
    assert list(tmp_path.iterdir()) == []  # nothing half-written


def test_write_puts_every_format_beside_the_stem(tmp_path):
    paths = table().write(tmp_path / "sub" / "servo", kinds=("md", "html", "csv", "json"))
    assert sorted(p.name for p in paths.values()) == [
        "servo.csv",
        "servo.html",
        "servo.json",
        "servo.md",
    ]
    assert paths["md"].read_text() == table().to_markdown()
    assert not [p for p in (tmp_path / "sub").iterdir() if p.name.startswith(".")]
