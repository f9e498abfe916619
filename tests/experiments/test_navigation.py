"""The navigation experiment's scoring: failure modes and the table, on rows of known
runs (the experiment itself runs in tests/experiments/test_runs.py)."""

import math

from flylog.experiments.navigation import _table, failure_mode


def _row(family="passages", **kw):
    row = {
        "family": family,
        "seed": 1000,
        "reachable": family != "dead-end",
        "success": True,
        "ending": "goal_reached",
        "end_time_s": 60.0,
        "goal_reached": True,
        "collisions": 0,
        "time_to_goal_s": 60.0,
        "path_length_m": 12.0,
        "optimal_path_m": 10.0,
        "path_over_optimal": 1.2,
        "narrowest_gap_m": 1.2,
        "min_clearance_m": 0.2,
    }
    row.update(kw)
    return row


def test_failure_modes():
    assert failure_mode(_row()) is None
    assert failure_mode(_row(success=False, collisions=2)) == "collision"
    assert failure_mode(_row(success=False, ending="duration")) == "time limit"
    assert failure_mode(_row(success=False, ending="stuck")) == "ended stuck"
    lost = _row(success=False, ending="unreachable")
    assert failure_mode(lost) == "said unreachable on a reachable world"
    dead = _row("dead-end", success=False, ending="duration", goal_reached=False)
    assert failure_mode(dead) == "dead end not recognised before the time limit"


def test_table_counts_and_the_median_ratio():
    runs = [
        _row(path_over_optimal=1.1),
        _row(path_over_optimal=1.3),
        _row(success=False, goal_reached=False, ending="duration", path_over_optimal=3.0),
        _row("dead-end", ending="unreachable", goal_reached=False, path_over_optimal=math.nan),
    ]
    rows = {r["family"]: r for r in _table(runs).rows}
    assert rows["passages"]["success"].k == 2 and rows["passages"]["success"].n == 3
    assert math.isclose(rows["passages"]["ratio_median"], 1.2)  # runs that reached the goal only
    assert rows["passages"]["ended"] == "duration 1, goal_reached 2"
    assert rows["dead-end"]["success"].k == 1
