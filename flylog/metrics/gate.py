"""A comparison (``flylog.metrics.compare``) as CI systems read it: one JSON object, or JUnit
XML with one test case per metric and a failure per regression.

A comparison of two sweeps has one group per grid point (its variant and grid values); a
comparison of metrics summaries is one group without a key. JSON numbers that are not
defined (a mean over no run, an unjudged metric's tolerance) are nulls.
"""

from __future__ import annotations

import math
import os
import xml.etree.ElementTree as ET
from collections.abc import Mapping, Sequence
from pathlib import Path
from typing import Any, NamedTuple

from flylog.config import to_mapping
from flylog.io.atomic import publish, temporary_beside
from flylog.metrics.compare import Comparison, MetricComparison, Tolerance

SUITE_NAME = "flylog compare"


class Group(NamedTuple):
    """The comparison of one grid point (``key`` empty for plain summaries)."""

    key: tuple[tuple[str, Any], ...]
    comparison: Comparison
    failed_base: int = 0  # cells of the point that failed (sweeps), left out of the means
    failed_candidate: int = 0


def _number(x: float) -> float | None:
    return None if math.isnan(x) else x


def metric_json(m: MetricComparison, tolerance: Tolerance | None) -> dict[str, Any]:
    return {
        "metric": m.name,
        "base": {"mean": _number(m.base_mean), "sd": _number(m.base_std)},
        "candidate": {"mean": _number(m.candidate_mean), "sd": _number(m.candidate_std)},
        "delta": _number(m.delta),
        "tolerance": None
        if tolerance is None
        else {**to_mapping(tolerance), "allowed": _number(m.allowed)},
        "verdict": m.verdict.value,
        "regressed": m.regressed,
    }


def comparison_json(groups: Sequence[Group], tolerances: Mapping[str, Tolerance]) -> dict[str, Any]:
    """One JSON-able object: ``regressed`` (any group), ``regressions`` (their names), and
    for each group its key, run counts and metrics."""
    out_groups = []
    regressions = []
    for g in groups:
        label = group_label(g.key)
        regressions += [f"{label}: {m.name}" if label else m.name for m in g.comparison.regressed]
        out_groups.append(
            {
                "key": {k: v for k, v in g.key},
                "n_base": g.comparison.n_base,
                "n_candidate": g.comparison.n_candidate,
                "failed_base": g.failed_base,
                "failed_candidate": g.failed_candidate,
                "metrics": [metric_json(m, tolerances.get(m.name)) for m in g.comparison.metrics],
            }
        )
    return {"regressed": bool(regressions), "regressions": regressions, "groups": out_groups}


def group_label(key: Sequence[tuple[str, Any]]) -> str:
    return ", ".join(f"{k}={v}" for k, v in key)


def _fmt(x: float) -> str:
    return "none" if math.isnan(x) else f"{x:.6g}"


def junit_xml(groups: Sequence[Group], tolerances: Mapping[str, Tolerance]) -> str:
    """JUnit XML: a test suite per group, a test case per metric; a regression (or a missing
    value) is a failure, a metric without tolerance is skipped."""
    root = ET.Element("testsuites", name=SUITE_NAME)
    total = failures = skipped = 0
    for g in groups:
        label = group_label(g.key)
        name = f"{SUITE_NAME}: {label}" if label else SUITE_NAME
        suite = ET.SubElement(root, "testsuite", name=name)
        n_fail = n_skip = 0
        for m in g.comparison.metrics:
            case = ET.SubElement(suite, "testcase", classname=SUITE_NAME, name=m.name)
            detail = (
                f"base {_fmt(m.base_mean)} ± {_fmt(m.base_std)} (n={g.comparison.n_base}), "
                f"candidate {_fmt(m.candidate_mean)} ± {_fmt(m.candidate_std)} "
                f"(n={g.comparison.n_candidate}), delta {_fmt(m.delta)}, "
                f"allowed {_fmt(m.allowed)}"
            )
            if m.regressed:
                n_fail += 1
                tol = tolerances.get(m.name)
                way = f", {tol.direction.value} is better" if tol is not None else ""
                failure = ET.SubElement(
                    case, "failure", message=f"{m.name}: {m.verdict.value}", type=m.verdict.value
                )
                failure.text = detail + way
            elif m.verdict.value == "-":
                n_skip += 1
                ET.SubElement(case, "skipped", message="not judged: no tolerance or no base value")
            ET.SubElement(case, "system-out").text = detail
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


def write_junit(path: Path, groups: Sequence[Group], tolerances: Mapping[str, Tolerance]) -> Path:
    """The JUnit XML of a comparison at ``path``, whole or not at all."""
    fd, tmp = temporary_beside(Path(path))
    try:
        with os.fdopen(fd, "w", encoding="utf-8") as fh:
            fh.write(junit_xml(groups, tolerances))
        publish(tmp, Path(path))
    finally:
        tmp.unlink(missing_ok=True)
    return Path(path)
