"""The gate itself (``flylog compare`` of two sweeps): its false alarms over A/A comparisons,
its power on three real regressions, and its run time per comparison.

Each configuration runs once over a pool of engine seeds (``gate_pools``: short logs of
``corridor`` and ``near-obstacle``, 2 s at 320×240); every comparison draws its 5 seeds a
side from those pools at random (a seeded generator), so the comparisons share runs: that
is how 100 comparisons of 10 runs fit in ~260 runs. Figures:

- false alarms: A/A comparisons, the default configuration against itself on disjoint
  seeds (unpaired), the share that exits 1; on the held-out seeds 20-39 and, apart, on the
  seeds 0-19 the default tolerances were set from;
- power: the share of comparisons that exit 1 when the candidate is a regression, with the
  candidate on the same 5 seeds as the base (paired, as a CI job runs them) and on 5 other
  seeds (unpaired); held-out seeds only;
- each regression's true effect: the difference of the means over its 20 seeds;
- the gate's time per comparison: reading both results tables, the test of every metric of
  every grid point and input, the JSON and the JUnit XML, in this process; and a fresh
  ``flylog compare`` process with ``--junit`` and ``--json`` files, start to exit;
- why rank tests and not a bootstrap: the coverage of 90 % intervals on samples of 5.
"""

from __future__ import annotations

import statistics
import subprocess
import sys
import time
from collections import Counter
from collections.abc import Mapping, Sequence
from pathlib import Path
from typing import Any

import numpy as np

from flylog.metrics.compare import DEFAULT_TOLERANCES, Direction
from flylog.metrics.gate import Group, comparison_json, junit_xml
from flylog.metrics.judge import Verdict
from flylog.sweep.compare import compare_results, input_name
from flylog.sweep.results import read_results, write_results

from .gate_pools import HELD_OUT_SEEDS, POOLS, TUNING_SEEDS, run_pool

SEEDS_A_SIDE = 5
COMPARISONS = 120
# The metrics whose true effect is reported (the judged ones the regressions move).
EFFECT_METRICS = ("precision", "recall", "f_score", "nearest_error_m", "obstacles_detected")


def _write(path: Path, rows: Sequence[Mapping[str, Any]], source: Path) -> Path:
    path.parent.mkdir(parents=True, exist_ok=True)
    write_results(path, (), list(rows), source)
    return path


def _pick(rows: list[dict], seeds: Sequence[int], inputs: set[str]) -> list[dict]:
    chosen = set(seeds)
    return [r for r in rows if r["seed"] in chosen and r["input"] in inputs]


class Gate:
    """Comparisons of seed subsets of the pools, timed."""

    def __init__(self, out_dir: Path) -> None:
        self.dir = out_dir / "comparisons"
        self.times: list[float] = []
        self.count = 0
        self.inconclusive: list[int] = []  # inconclusive metrics per comparison
        self.tested: list[int] = []  # metrics tested (judged) per comparison
        self.last: list[Group] = []  # the groups of the latest comparison

    def exits_1(self, base: list[dict], candidate: list[dict], source: Path) -> bool:
        self.count += 1
        b = _write(self.dir / f"{self.count}-base" / "results.parquet", base, source)
        c = _write(self.dir / f"{self.count}-cand" / "results.parquet", candidate, source)
        t0 = time.perf_counter()
        result = compare_results(b, c, DEFAULT_TOLERANCES)
        comparison_json(result.groups, DEFAULT_TOLERANCES)
        junit_xml(result.groups, DEFAULT_TOLERANCES)
        self.times.append(time.perf_counter() - t0)
        self.last = result.groups
        metrics = [m for g in result.groups for m in g.comparison.metrics]
        self.inconclusive.append(sum(m.verdict is Verdict.INCONCLUSIVE for m in metrics))
        self.tested.append(sum(m.judgement.shift is not None for m in metrics))
        for path in (b, c):
            path.unlink()
            path.parent.rmdir()
        return any(g.comparison.regressed for g in result.groups)


def _aa(gate: Gate, rows: list[dict], seeds: Sequence[int], rng, source: Path) -> float:
    inputs = {r["input"] for r in rows}
    hits = 0
    for _ in range(COMPARISONS):
        drawn = rng.choice(seeds, size=2 * SEEDS_A_SIDE, replace=False)
        a, b = drawn[:SEEDS_A_SIDE], drawn[SEEDS_A_SIDE:]
        hits += gate.exits_1(_pick(rows, a, inputs), _pick(rows, b, inputs), source)
    return hits / COMPARISONS


def _worsened(base: list[dict], cand: list[dict]) -> set[tuple[str, str]]:
    """(input name, metric) whose mean over the held-out seeds got worse beyond the
    metric's default tolerance: what a comparison should not call "no change"."""
    out = set()
    for inp in {r["input"] for r in cand}:
        for name, tol in DEFAULT_TOLERANCES.items():
            b = np.array([r.get(name) for r in _pick(base, HELD_OUT_SEEDS, {inp})], dtype=float)
            c = np.array([r.get(name) for r in _pick(cand, HELD_OUT_SEEDS, {inp})], dtype=float)
            if not (np.isfinite(b).any() and np.isfinite(c).any()):
                continue
            shift = float(np.nanmean(c) - np.nanmean(b))
            worse = -shift if tol.direction is Direction.HIGHER else shift
            if worse > tol.allowed(float(np.nanmean(b))):
                out.add((input_name(inp), name))
    return out


def _power(
    gate: Gate, base: list[dict], cand: list[dict], rng, source: Path, *, paired: bool
) -> tuple[float, Counter[str]]:
    """The share of comparisons that exit 1, and in those that pass, the verdicts on the
    metrics the change worsened beyond their tolerance."""
    inputs = {r["input"] for r in cand}
    worsened = _worsened(base, cand)
    seeds = list(HELD_OUT_SEEDS)
    hits = 0
    missed: Counter[str] = Counter()
    for _ in range(COMPARISONS):
        drawn = rng.choice(seeds, size=2 * SEEDS_A_SIDE, replace=False)
        a = drawn[:SEEDS_A_SIDE]
        b = a if paired else drawn[SEEDS_A_SIDE:]
        if gate.exits_1(_pick(base, a, inputs), _pick(cand, b, inputs), source):
            hits += 1
            continue
        for g in gate.last:
            where = str(dict(g.key)["input"])
            missed.update(
                m.verdict.value for m in g.comparison.metrics if (where, m.name) in worsened
            )
    return hits / COMPARISONS, missed


def _effects(base: list[dict], cand: list[dict]) -> list[str]:
    """Per input, the difference of the means over the held-out seeds, in base sds."""
    out = []
    for inp in sorted({r["input"] for r in cand}):
        parts = []
        for m in EFFECT_METRICS:
            b = np.array([r[m] for r in _pick(base, HELD_OUT_SEEDS, {inp})], dtype=float)
            c = np.array([r[m] for r in _pick(cand, HELD_OUT_SEEDS, {inp})], dtype=float)
            sd = float(np.nanstd(b, ddof=1))
            effect = float(np.nanmean(c) - np.nanmean(b))
            in_sd = f" ({effect / sd:+.1f} sd)" if sd > 0 else ""
            parts.append(f"{m} {effect:+.3g}{in_sd}")
        out.append(f"{Path(inp.split('@')[0]).stem}: " + ", ".join(parts))
    return out


def _cli_seconds(out_dir: Path, base: list[dict], cand: list[dict], source: Path) -> float:
    """A fresh ``flylog compare`` process with --junit and --json files, best of 3."""
    b = _write(out_dir / "cli" / "base" / "results.parquet", base, source)
    c = _write(out_dir / "cli" / "cand" / "results.parquet", cand, source)
    exe = Path(sys.executable).parent / "flylog"
    best = float("inf")
    for _ in range(3):
        t0 = time.perf_counter()
        files = ["--junit", str(out_dir / "cli" / "gate.xml")]
        files += ["--json", str(out_dir / "cli" / "gate.json")]
        subprocess.run(
            [str(exe), "compare", str(b), str(c), *files], check=False, capture_output=True
        )
        best = min(best, time.perf_counter() - t0)
    return best


def interval_coverage(trials: int = 4000, boots: int = 2000) -> dict[str, float]:
    """How often a 90 % interval holds a true shift of 0, samples of 5 normal values (5 + 5
    unpaired, 5 differences paired): the percentile bootstrap of the mean difference
    against the rank tests' intervals (``flylog.metrics.shift``)."""
    from flylog.metrics.shift import paired_shift, unpaired_shift

    rng = np.random.default_rng(1)
    hits = dict.fromkeys(("bootstrap unpaired", "mann-whitney", "bootstrap paired", "wilcoxon"), 0)
    for _ in range(trials):
        x, y, d = rng.normal(size=5), rng.normal(size=5), rng.normal(size=5)
        resampled = y[rng.integers(0, 5, (boots, 5))].mean(1)
        resampled -= x[rng.integers(0, 5, (boots, 5))].mean(1)
        lo, hi = np.quantile(resampled, [0.05, 0.95])
        hits["bootstrap unpaired"] += lo <= 0 <= hi
        lo, hi = np.quantile(d[rng.integers(0, 5, (boots, 5))].mean(1), [0.05, 0.95])
        hits["bootstrap paired"] += lo <= 0 <= hi
        s = unpaired_shift(x, y, 0.05)
        hits["mann-whitney"] += s.low <= 0 <= s.high
        s = paired_shift(np.zeros(5), d, 0.05)
        hits["wilcoxon"] += s.low <= 0 <= s.high
    return {k: v / trials for k, v in hits.items()}


def run(out_dir: Path) -> list[dict]:
    root = out_dir / "gate"
    t0 = time.perf_counter()
    pools = {name: run_pool(name, root) for name in POOLS}
    pool_s = time.perf_counter() - t0
    cells = sum(len(p.rows) for p in pools.values())
    source = pools["base"].spec.source
    rows = {name: read_results(p.results)[1] for name, p in pools.items()}
    rng = np.random.default_rng(34)
    gate = Gate(root)
    figures: list[dict] = []
    held = _aa(gate, rows["base"], list(HELD_OUT_SEEDS), rng, source)
    aa_inconclusive, aa_tested = list(gate.inconclusive), list(gate.tested)
    tuned = _aa(gate, rows["base"], list(TUNING_SEEDS), rng, source)
    note = f"{COMPARISONS} comparisons, {SEEDS_A_SIDE} disjoint seeds a side, 2 inputs"
    for seeds, share in (("held-out seeds 20-39", held), ("tuning seeds 0-19", tuned)):
        figures.append(
            {"name": f"false alarms, A/A, {seeds}", "value": 100 * share, "unit": "%", "note": note}
        )
    figures.append(
        {
            "name": "A/A inconclusive metrics per comparison, held-out seeds",
            "value": statistics.mean(aa_inconclusive),
            "unit": "",
            "note": f"of {statistics.mean(aa_tested):.0f} tested; comparisons with none: "
            f"{100 * sum(n == 0 for n in aa_inconclusive) / len(aa_inconclusive):.0f} %",
        }
    )
    for name in POOLS:
        if name == "base":
            continue
        for paired in (True, False):
            power, missed = _power(gate, rows["base"], rows[name], rng, source, paired=paired)
            how = "same seeds, paired" if paired else "disjoint seeds, unpaired"
            passing = "verdicts in the passing ones on the metrics it worsened beyond " + (
                "tolerance: " + ", ".join(f"{v} {n}" for v, n in sorted(missed.items()))
                if missed
                else "tolerance: none"
            )
            figures.append(
                {
                    "name": f"power, {name} ({how})",
                    "value": 100 * power,
                    "unit": "%",
                    "note": f"{COMPARISONS} comparisons, held-out seeds; {passing}; true "
                    "effect over 20 seeds: " + "; ".join(_effects(rows["base"], rows[name])),
                }
            )
    t = sorted(gate.times)
    figures.append(
        {
            "name": "gate time per comparison (in process)",
            "value": 1000 * statistics.median(t),
            "unit": "ms",
            "note": f"median of {len(t)}; 90th percentile {1000 * t[int(0.9 * len(t))]:.0f} ms; "
            "2 inputs × 5 seeds a side, reading, tests, JSON and JUnit",
        }
    )
    inputs = {r["input"] for r in rows["base"]}
    cli = _cli_seconds(
        root,
        _pick(rows["base"], HELD_OUT_SEEDS[:5], inputs),
        _pick(rows["base"], HELD_OUT_SEEDS[5:10], inputs),
        source,
    )
    figures.append(
        {
            "name": "flylog compare process, start to exit",
            "value": cli,
            "unit": "s",
            "note": "best of 3, --junit and --json files, 2 inputs × 5 seeds a side",
        }
    )
    coverage = interval_coverage()
    for name, share in coverage.items():
        figures.append(
            {
                "name": f"coverage of a 90 % interval, {name}",
                "value": 100 * share,
                "unit": "%",
                "note": "4000 draws of 5 normal values a side (or 5 differences), shift 0",
            }
        )
    figures.append(
        {
            "name": "seed pools (sweeps, reused when already run)",
            "value": pool_s,
            "unit": "s",
            "note": f"{cells} cells on 2 workers",
        }
    )
    return figures
