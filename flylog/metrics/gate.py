"""A comparison (``flylog.metrics.compare``) as CI systems read it: one JSON object, or JUnit
XML with one test case per metric: a failure per regression, a skipped case per metric
inconclusive (with the reason and the seeds a side that would settle it) or not judged.

A comparison of two sweeps has one group per grid point and input (its variant, grid
values and input); a comparison of metrics summaries is one group without a key. JSON
numbers that are not defined (a mean over no run, an unjudged metric's tolerance, an
interval's open end) are nulls.
"""

from __future__ import annotations

import json
import math
import os
import xml.etree.ElementTree as ET
from collections.abc import Mapping, Sequence
from pathlib import Path
from typing import Any, NamedTuple

from flylog.config import to_mapping
from flylog.io.atomic import publish, temporary_beside
from flylog.metrics.compare import Comparison, MetricComparison, Tolerance
from flylog.metrics.judge import Verdict

SUITE_NAME = "flylog compare"


class Group(NamedTuple):
    """The comparison of one grid point and input (``key`` empty for plain summaries)."""

    key: tuple[tuple[str, Any], ...]
    comparison: Comparison
    failed_base: int = 0  # cells of the point that failed (sweeps), left out
    failed_candidate: int = 0
    input_damage: tuple[str, ...] = ()  # what the sweeps say of damaged inputs (sweeps)


def _number(x: float | None) -> float | None:
    return None if x is None or not math.isfinite(x) else x


def interval_level(alpha: float) -> float:
    """Confidence of the two-sided interval whose ends are the tests' 1 − α bounds."""
    return 1.0 - 2.0 * alpha


def metric_json(m: MetricComparison, tolerance: Tolerance | None) -> dict[str, Any]:
    j = m.judgement
    s = j.shift
    test: dict[str, Any] | None = None
    if s is not None:
        test = {
            "name": s.test,
            "paired": s.paired,
            "n_base": s.n_base,
            "n_candidate": s.n_candidate,
            "shift": _number(s.estimate),
            "interval": [_number(s.low), _number(s.high)],
            "p_regression": _number(j.p_regression),
            "p_improvement": _number(j.p_improvement),
            "p_no_change": _number(j.p_no_change),
        }
    return {
        "metric": m.name,
        "kind": m.kind.value,
        "base": {"mean": _number(m.base_mean), "sd": _number(m.base_std)},
        "candidate": {"mean": _number(m.candidate_mean), "sd": _number(m.candidate_std)},
        "delta": _number(m.delta),
        "tolerance": None
        if tolerance is None or j.verdict is Verdict.UNJUDGED
        else {**to_mapping(tolerance), "allowed": _number(j.allowed)},
        "test": test,
        "verdict": j.verdict.value,
        "reason": j.reason or None,
        "seeds_needed": j.seeds_needed,
        "regressed": m.regressed,
    }


def comparison_json(groups: Sequence[Group], tolerances: Mapping[str, Tolerance]) -> dict[str, Any]:
    """One JSON-able object: ``regressed`` (any group), ``regressions`` and
    ``inconclusive`` (their names), the significance and the interval's confidence, and
    for each group its key, run counts, pairing, damaged input and metrics."""
    out_groups = []
    regressions, inconclusive = [], []
    alpha = groups[0].comparison.alpha if groups else math.nan
    for g in groups:
        label = group_label(g.key)
        for m in g.comparison.metrics:
            name = f"{label}: {m.name}" if label else m.name
            if m.regressed:
                regressions.append(name)
            elif m.verdict is Verdict.INCONCLUSIVE:
                inconclusive.append(name)
        out_groups.append(
            {
                "key": {k: v for k, v in g.key},
                "n_base": g.comparison.n_base,
                "n_candidate": g.comparison.n_candidate,
                "paired": g.comparison.paired,
                "open_loop": g.comparison.open_loop,
                "failed_base": g.failed_base,
                "failed_candidate": g.failed_candidate,
                "input_damaged": bool(g.input_damage),
                "input_damage": list(g.input_damage),
                "metrics": [metric_json(m, tolerances.get(m.name)) for m in g.comparison.metrics],
            }
        )
    return {
        "regressed": bool(regressions),
        "regressions": regressions,
        "inconclusive": inconclusive,
        "alpha": _number(alpha),
        "interval_confidence": _number(interval_level(alpha)),
        "groups": out_groups,
    }


def group_label(key: Sequence[tuple[str, Any]]) -> str:
    return ", ".join(f"{k}={v}" for k, v in key)


def _fmt(x: float) -> str:
    return "none" if not math.isfinite(x) else f"{x:.6g}"


def detail(m: MetricComparison, comparison: Comparison) -> str:
    """One line of a metric's figures: means, shift, interval, test, p-values."""
    j, s = m.judgement, m.judgement.shift
    text = (
        f"base {_fmt(m.base_mean)} ± {_fmt(m.base_std)} (n={comparison.n_base}), "
        f"candidate {_fmt(m.candidate_mean)} ± {_fmt(m.candidate_std)} "
        f"(n={comparison.n_candidate})"
    )
    if s is None:
        return f"{text}; {m.kind.value} metric" + (f", {j.reason}" if j.reason else "")
    level = interval_level(comparison.alpha)
    return (
        f"{text}; shift {_fmt(s.estimate)}, {level:.0%} interval "
        f"[{_fmt(s.low)}, {_fmt(s.high)}], allowed worsening {_fmt(j.allowed)}; "
        f"{s.test} ({'paired' if s.paired else 'unpaired'}, n={s.n_base}/{s.n_candidate}): "
        f"p_regression {_fmt(j.p_regression)}, p_improvement {_fmt(j.p_improvement)}, "
        f"p_no_change {_fmt(j.p_no_change)}"
    )


def _skip_message(m: MetricComparison) -> str:
    j = m.judgement
    if j.verdict is Verdict.INCONCLUSIVE:
        return f"inconclusive: {j.reason}"
    return f"not judged: {j.reason}"


def junit_xml(groups: Sequence[Group], tolerances: Mapping[str, Tolerance]) -> str:
    """JUnit XML: a test suite per group, a test case per metric; a regression (or a missing
    value) is a failure, an inconclusive or unjudged metric is skipped with its reason."""
    root = ET.Element("testsuites", name=SUITE_NAME)
    total = failures = skipped = 0
    for g in groups:
        label = group_label(g.key)
        name = f"{SUITE_NAME}: {label}" if label else SUITE_NAME
        suite = ET.SubElement(root, "testsuite", name=name)
        if g.input_damage:
            props = ET.SubElement(suite, "properties")
            ET.SubElement(props, "property", name="input_damaged", value="; ".join(g.input_damage))
        n_fail = n_skip = 0
        for m in g.comparison.metrics:
            case = ET.SubElement(suite, "testcase", classname=name, name=m.name)
            text = detail(m, g.comparison)
            if g.input_damage:
                text += "; input damaged: " + "; ".join(g.input_damage)
            if m.regressed:
                n_fail += 1
                tol = tolerances.get(m.name)
                way = f", {tol.direction.value} is better" if tol is not None else ""
                failure = ET.SubElement(
                    case, "failure", message=f"{m.name}: {m.verdict.value}", type=m.verdict.value
                )
                failure.text = text + way
            elif m.verdict in (Verdict.INCONCLUSIVE, Verdict.UNJUDGED):
                n_skip += 1
                ET.SubElement(case, "skipped", message=_skip_message(m))
            ET.SubElement(case, "system-out").text = text
        suite.set("tests", str(len(g.comparison.metrics)))
        suite.set("failures", str(n_fail))
        suite.set("errors", "0")
        suite.set("skipped", str(n_skip))
        total += len(g.comparison.metrics)
        failures += n_fail
        skipped += n_skip
    root.set("tests", str(total))
    root.set("failures", str(failures))
    root.set("errors", "0")
    root.set("skipped", str(skipped))
    ET.indent(root)
    return ET.tostring(root, encoding="unicode", xml_declaration=True) + "\n"


def _write_text(path: Path, text: str) -> Path:
    fd, tmp = temporary_beside(Path(path))
    try:
        with os.fdopen(fd, "w", encoding="utf-8") as fh:
            fh.write(text)
        publish(tmp, Path(path))
    finally:
        tmp.unlink(missing_ok=True)
    return Path(path)


def write_junit(path: Path, groups: Sequence[Group], tolerances: Mapping[str, Tolerance]) -> Path:
    """The JUnit XML of a comparison at ``path``, whole or not at all."""
    return _write_text(path, junit_xml(groups, tolerances))


def json_text(groups: Sequence[Group], tolerances: Mapping[str, Tolerance]) -> str:
    return json.dumps(comparison_json(groups, tolerances), indent=2) + "\n"


def write_json(path: Path, groups: Sequence[Group], tolerances: Mapping[str, Tolerance]) -> Path:
    """The JSON of a comparison at ``path``, whole or not at all."""
    return _write_text(path, json_text(groups, tolerances))
