"""The pure parts of benches/gtsam_same_graph.py: how iSAM2 is scheduled on
our keyframe window's updates, and how our per-update time is summed
(no GTSAM solve: they run whether gtsam is installed or not)."""

from __future__ import annotations

import sys
from pathlib import Path
from typing import Any

import pytest

sys.path.insert(0, str(Path(__file__).resolve().parents[2] / "benches"))

import gtsam_same_graph as bench


def test_every_node_lands_in_the_update_that_first_reaches_it() -> None:
    # The start's solve on node 0, keyframes on 3 and 7, the run's end on 9.
    groups = bench.schedule_groups(range(10), [0, 3, 7, 9])
    assert groups == [[0], [1, 2, 3], [4, 5, 6, 7], [8, 9]]


def test_nodes_after_the_last_update_are_one_more_group() -> None:
    groups = bench.schedule_groups([3, 0, 2, 1, 4, 5], [0, 2])
    assert groups == [[0], [1, 2], [3, 4, 5]]


def test_an_update_on_a_node_already_taken_gets_an_empty_group() -> None:
    # A last solve for scans that did not move: no new node for iSAM2.
    groups = bench.schedule_groups(range(4), [0, 3, 3])
    assert groups == [[0], [1, 2, 3], []]
    assert sorted(n for g in groups for n in g) == list(range(4))


def test_one_update_per_node_is_the_per_node_schedule() -> None:
    assert bench.schedule_groups(range(5), range(5)) == [[n] for n in range(5)]


def test_a_decreasing_schedule_is_refused() -> None:
    with pytest.raises(ValueError, match="must not decrease"):
        bench.schedule_groups(range(5), [0, 3, 2])


def test_our_update_is_its_solve_plus_the_scans_it_first_includes() -> None:
    problem: dict[str, Any] = {
        "keyframe_update_times_s": [1.0, 2.0, 3.0],
        "keyframe_scan_updates": [1, 1, 2, 2, 2],
        "keyframe_scan_graph_times_s": [0.1, 0.2, 0.01, 0.02, 0.03],
    }
    totals = bench.keyframe_update_totals(problem)
    assert totals == pytest.approx([1.0, 2.3, 3.06])
    assert sum(totals) == pytest.approx(6.36)


def test_the_verdict_is_computed_from_the_ratios() -> None:
    rows = [{"robot": 1, "r": 0.5}, {"robot": 2, "r": 1.5}]
    line = bench.verdict(rows, "r", "x")
    assert "0.50–1.50" in line
    assert "≤ 1 on robots 1, > 1 on robots 2" in line
    assert "**met**" not in line
    assert "**met**" in bench.verdict(rows[:1], "r", "x")
    assert "**not met**" in bench.verdict(rows[1:], "r", "x")


def test_a_ratio_in_the_text_has_three_digits_and_no_exponent() -> None:
    assert bench._factor(1573.5995) == "1574"
    assert bench._factor(1.24137) == "1.24"
    assert bench._factor(50.6032) == "50.6"
