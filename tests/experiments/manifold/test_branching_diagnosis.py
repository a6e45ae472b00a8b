"""The branching-sequence diagnosis (the full run is in the docs)."""

import json

import numpy as np
import pytest

from experiments.manifold.branching_diagnosis import branch_start_ratios, main
from experiments.manifold.split_manifold import normalised_cut


def test_normalised_cut_of_a_leaf_grouping():
    # two blocks of two leaves, weakly joined: cutting between the blocks is cheap
    A = np.array([[4.0, 3, 0.1, 0.1], [3, 4, 0.1, 0.1], [0.1, 0.1, 4, 3], [0.1, 0.1, 3, 4]])
    good = normalised_cut(A, np.array([0, 0, 1, 1]))
    bad = normalised_cut(A, np.array([0, 1, 0, 1]))
    assert good == pytest.approx(2 * 0.2 / 7.2)
    assert bad > 5 * good


def test_branch_start_ratio_says_which_arm_a_start_is_tied_to():
    # labels 0 (trunk) and 1 (branch), 4 points each; leaves: trunk, branch start, branch rest
    y = np.array([0, 0, 0, 0, 1, 1, 1, 1])
    leaves = [np.arange(4), np.array([4, 5]), np.array([6, 7])]
    tied_to_trunk = np.array([[1, 0.9, 0.2], [0.9, 1, 0.5], [0.2, 0.5, 1]])
    assert branch_start_ratios(y, leaves, tied_to_trunk, 4, 2) == [pytest.approx(1.8)]
    tied_along = np.array([[1, 0.3, 0.2], [0.3, 1, 0.6], [0.2, 0.6, 1]])
    assert branch_start_ratios(y, leaves, tied_along, 4, 2) == [pytest.approx(0.5)]


def test_diagnose_one_small_draw(tmp_path):
    out = tmp_path / "d.json"
    args = ["--n", "160", "--draws", "0", "--Q", "5", "--top-alpha-only", "--out", str(out)]
    assert main(args) == 0
    (row,) = json.loads(out.read_text())
    assert row["kernel path"] == "DenseGeometry" and row["leaves"] >= 8
    assert 0 <= row["bound"] <= row["error"] <= 1
    assert row["cut over the grid, best"] <= row["cut over the grid, median"]
    assert len(row["branch-start ratios"]) == 6  # three branches per world


def test_share_at_the_bound_counts_only_the_cells_redone(monkeypatch):
    # with a bound every cut reaches, every cell redone (the top alpha's 16) is at the bound
    import experiments.manifold.branching_diagnosis as diagnosis

    monkeypatch.setattr(diagnosis, "majority_merge_error", lambda y, leaves: 1.0)
    row = diagnosis.diagnose(160, 0, Q=5, every_alpha=False)
    assert row["grid cells at the bound"] == 1.0


def test_too_few_points_are_refused():
    with pytest.raises(SystemExit):
        main(["--n", "100", "--Q", "35"])
