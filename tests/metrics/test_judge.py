"""Verdicts of flylog.metrics.judge on hand-made samples."""

from __future__ import annotations

import math

import pytest

from flylog.metrics.judge import Direction, Verdict, judge, seeds_needed
from flylog.metrics.shift import unpaired_shift

HI, LO = Direction.HIGHER, Direction.LOWER


def verdict(base, cand, direction=HI, allowed=0.02, paired=False, alpha=0.05):
    return judge(base, cand, direction=direction, allowed=allowed, paired=paired, alpha=alpha)


BASE = [0.80, 0.81, 0.79, 0.80, 0.805]


@pytest.mark.parametrize(
    ("shift", "direction", "expected"),
    [
        (-0.10, HI, Verdict.REGRESSION),
        (+0.10, HI, Verdict.IMPROVEMENT),
        (+0.10, LO, Verdict.REGRESSION),
        (-0.10, LO, Verdict.IMPROVEMENT),
        (0.0, HI, Verdict.NO_CHANGE),
        (-0.02, HI, Verdict.NO_CHANGE),  # exactly the worsening allowed
    ],
)
def test_verdict_by_shift_and_direction(shift, direction, expected) -> None:
    got = verdict(BASE, [b + shift for b in BASE], direction, paired=True)
    assert got.verdict is expected
    assert got.regressed is (expected is Verdict.REGRESSION)


def test_a_shift_inside_the_tolerance_is_no_regression_however_sure() -> None:
    # every seed 0.015 lower, tolerance 0.02: certain, but within what is allowed
    got = verdict(BASE, [b - 0.015 for b in BASE], paired=True)
    assert got.verdict is Verdict.NO_CHANGE and got.p_regression == 1.0
    got = verdict(BASE, [b - 0.015 for b in BASE], allowed=0.01, paired=True)
    assert got.verdict is Verdict.REGRESSION and got.p_regression == 1 / 32


def test_p_values_follow_the_interval() -> None:
    got = verdict(BASE, [b - 0.1 for b in BASE], paired=True)
    s = got.shift
    assert s is not None and s.paired and s.n_base == 5
    assert s.low == pytest.approx(-0.1) and s.high == pytest.approx(-0.1)
    assert got.p_regression == 1 / 32 and got.p_improvement == 1.0
    assert got.p_no_change == 1.0


def test_inconclusive_says_why_and_how_many_seeds() -> None:
    base = [0.80, 0.84, 0.76, 0.82, 0.78]
    cand = [0.79, 0.83, 0.75, 0.81, 0.77]
    got = verdict(base, cand)
    assert got.verdict is Verdict.INCONCLUSIVE and not got.regressed
    assert "worsening beyond 0.02 is not ruled out" in got.reason
    assert got.seeds_needed is not None and got.seeds_needed > 5
    assert f"about {got.seeds_needed} seeds a side needed (5 now)" in got.reason
    few = verdict([0.8, 0.8], [0.5, 0.5], paired=True)
    assert few.verdict is Verdict.INCONCLUSIVE
    assert few.reason == "too few runs for an interval (2 pairs); at least 5 pairs needed"
    assert few.seeds_needed == 5  # 2⁻⁵ ≤ 0.05: the fewest pairs with an interval
    one = verdict([0.8], [0.5])  # no spread measured: the fewest with an interval
    assert (
        one.reason == "too few runs for an interval (1 seed a side); at least 3 seeds a side needed"
    )


def test_seeds_needed_by_hand() -> None:
    """Unpaired, sd 0.02 a side, the estimate 0.01 from the tolerance it straddles:
    n ≥ 2 · (z₀.₉₅ · 0.02 / 0.01)² = 2 · 3.29² = 21.6 → 22."""
    shift = unpaired_shift([0.0, 0.0, 0.0], [-0.01, -0.01, -0.01], alpha=0.05)
    shift = shift._replace(low=-0.05, high=0.03)
    assert seeds_needed(shift, 0.02, 0.02, 0.05, -1.0) == 22
    assert seeds_needed(shift._replace(estimate=-0.02), 0.02, 0.02, 0.05, -1.0) is None
    assert seeds_needed(shift, math.nan, 0.02, 0.05, -1.0) is None


def test_missing_and_unjudged() -> None:
    assert verdict(BASE, [math.nan] * 5).verdict is Verdict.MISSING
    assert verdict([math.nan] * 5, BASE).verdict is Verdict.UNJUDGED
    # pairs with a null on either side are left out
    got = verdict([*BASE, 0.8], [*BASE, math.nan], paired=True)
    assert got.shift is not None and got.shift.n_base == 5
