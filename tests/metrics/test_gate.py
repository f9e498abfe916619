from __future__ import annotations

import json
import xml.etree.ElementTree as ET
from pathlib import Path

import pytest
from click.testing import CliRunner

from flylog.cli.compare import compare as compare_command

from .test_compare import write_summary


@pytest.fixture
def pair(tmp_path: Path) -> tuple[Path, Path]:
    base = write_summary(tmp_path / "base.parquet")
    cand = write_summary(tmp_path / "cand.parquet", precision=0.70, ate_m=0.105)
    return base, cand


def test_json_is_one_object_with_every_metrics_figures(pair) -> None:
    got = CliRunner().invoke(compare_command, [*map(str, pair), "--json"])
    assert got.exit_code == 1, got.output
    report = json.loads(got.output)  # nothing else on stdout
    assert report["regressed"] is True and report["regressions"] == ["precision"]
    (group,) = report["groups"]
    assert (group["key"], group["n_base"], group["n_candidate"]) == ({}, 1, 1)
    metrics = {m["metric"]: m for m in group["metrics"]}
    p = metrics["precision"]
    assert p["base"] == {"mean": 0.8, "sd": 0.0} and p["candidate"]["mean"] == 0.7
    assert p["delta"] == pytest.approx(-0.1)
    assert p["tolerance"] == {"direction": "higher", "absolute": 0.02, "relative": 0.0,
                              "allowed": 0.02}  # fmt: skip
    assert p["verdict"] == "regression" and p["regressed"] is True
    ate = metrics["ate_m"]
    assert ate["verdict"] == "ok" and ate["tolerance"]["allowed"] == pytest.approx(0.01)
    assert metrics["wall_s"]["tolerance"] is None and metrics["wall_s"]["verdict"] == "-"
    assert metrics["recall"]["base"]["mean"] is None  # a null summary value


def test_junit_has_a_case_per_metric_and_a_failure_per_regression(pair, tmp_path) -> None:
    out = tmp_path / "gate.xml"
    got = CliRunner().invoke(compare_command, [*map(str, pair), "--junit", str(out)])
    assert got.exit_code == 1 and "regression" in got.output
    root = ET.parse(out).getroot()
    (suite,) = root.findall("testsuite")
    cases = {c.get("name"): c for c in suite.findall("testcase")}
    assert int(suite.get("tests")) == len(cases) == int(root.get("tests"))
    failures = [name for name, c in cases.items() if c.find("failure") is not None]
    assert failures == ["precision"] and suite.get("failures") == "1"
    assert "base 0.8" in cases["precision"].find("failure").text
    assert cases["wall_s"].find("skipped") is not None
    assert cases["ate_m"].find("failure") is None and cases["ate_m"].find("skipped") is None


def test_no_regression_exits_0_in_both_forms(pair, tmp_path) -> None:
    base, _ = pair
    out = tmp_path / "ok.xml"
    got = CliRunner().invoke(compare_command, [str(base), str(base), "--json", "--junit", str(out)])
    assert got.exit_code == 0 and json.loads(got.output)["regressed"] is False
    assert ET.parse(out).getroot().get("failures") == "0"
