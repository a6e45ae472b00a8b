"""A held-out cell's servo task in a generated world, its cache, and the cells run on the
sweep's local backend."""

import pytest

import scripts.heldout.servo_cell as servo_cell
from scripts.heldout import run_cell
from scripts.heldout.cells import MANIFOLD_Q, OURS_SCALED, scaled_q
from scripts.heldout.evaluate import CellRunner
from scripts.heldout.servo_cell import spread_by_junctions
from scripts.manifold import OURS, SKLEARN_DEFAULT
from scripts.sweep.backends import open_backend

WORLD = "hallway:11000"  # a bend: two manifolds, one junction apart
FRAMES = 100


@pytest.fixture(scope="module")
def cell_dirs(tmp_path_factory):
    root = tmp_path_factory.mktemp("heldout")
    return root / "out", root / "data"


def test_the_servo_task_runs_both_controllers_and_tiers(cell_dirs):
    out, data = cell_dirs
    cell = run_cell(WORLD, 0, out, data, FRAMES, tasks=("servo",), episodes=1)
    servo = cell["tasks"]["servo"]
    assert servo["split"] == "test" and servo["episodes"] == 1 and servo["map_views"] > 0
    keys = [(r["policy"], r["tier"]) for r in servo["records"]]
    assert keys == [
        ("servo", "view"),
        ("servo", "anywhere"),
        ("signal", "view"),
        ("signal", "anywhere"),
    ]
    for r in servo["records"]:
        assert r["junctions"] == 1 and isinstance(r["success"], bool)
        assert {r["start_manifold"], r["target_manifold"]} == set(cell["manifolds"])
    assert sorted(cell["junctions"].values()) == [0, 1]


def test_a_cached_cell_is_not_run_again_unless_the_episodes_change(cell_dirs, monkeypatch):
    out, data = cell_dirs
    first = run_cell(WORLD, 0, out, data, FRAMES, tasks=("servo",), episodes=1)
    calls = []

    def counted(data_, world, episodes):
        calls.append(episodes)
        return {"episodes": episodes, "split": "test", "map_views": 0, "records": []}

    monkeypatch.setattr(servo_cell, "servo_task", counted)
    assert run_cell(WORLD, 0, out, data, FRAMES, tasks=("servo",), episodes=1) == first
    assert calls == []
    again = run_cell(WORLD, 0, out, data, FRAMES, tasks=("servo",), episodes=2)
    assert calls == [2] and again["tasks"]["servo"]["episodes"] == 2


def test_cells_run_on_the_sweeps_local_backend(cell_dirs, monkeypatch):
    out, data = cell_dirs
    # the cached cell of the test above, through the backend's own worker processes
    with open_backend("local", 1) as workers:
        workers.start_runner(CellRunner, out, data, FRAMES, ("servo",))
        [(i, cell)] = list(workers.run([(WORLD, 0, 2)]))
    assert i == 0 and cell["world"] == WORLD and cell["tasks"]["servo"]["episodes"] == 2


def test_the_manifold_task_scales_q_to_the_data_and_records_a_refusal(cell_dirs):
    out, data = cell_dirs
    cell = run_cell(WORLD, 0, out, data, FRAMES, tasks=("manifold",))
    m = cell["tasks"]["manifold"]
    rows = {r["method"]: r for r in m["rows"]}
    assert m["k"] == 2 and m["n_train"] == FRAMES // 2
    # 50 training images cannot hold 2 clusters of the protocol's Q = 35: refused, not scored
    assert rows[OURS]["q"] == MANIFOLD_Q and rows[OURS]["test_error"] is None
    assert "refused" in rows[OURS]
    assert rows[OURS_SCALED]["q"] == scaled_q(FRAMES // 2, 2) == 8
    assert 0 <= rows[OURS_SCALED]["test_error"] <= 0.5
    assert 0 <= rows[SKLEARN_DEFAULT]["test_error"] <= 0.5
    assert [scaled_q(n, k) for n, k in ((225, 4), (525, 12), (2000, 4), (20, 3))] == [18, 14, 35, 8]


def test_episodes_spread_over_junction_counts_in_turn():
    pairs = [("m", "a"), ("m", "b"), ("m", "c"), ("a", "b"), ("a", "c"), ("b", "c")]
    far = {("m", "a"): 1, ("m", "b"): 1, ("m", "c"): 2, ("a", "b"): 2, ("a", "c"): 5, ("b", "c"): 3}
    assert spread_by_junctions(pairs, lambda a, b: far[a, b], 4) == [0, 2, 4, 1]
    assert spread_by_junctions(pairs, lambda a, b: far[a, b], 8) == [0, 2, 4, 1, 3, 5, 6, 7]
    assert spread_by_junctions(pairs[:2], lambda a, b: 1, 2) == [0, 1]
