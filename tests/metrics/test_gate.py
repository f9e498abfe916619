from __future__ import annotations

import json
import xml.etree.ElementTree as ET
from pathlib import Path

import pytest
from click.testing import CliRunner

from flylog.cli.compare import compare as compare_command
from flylog.metrics.compare import DEFAULT_TOLERANCES

from .test_compare import write_summary

BASE_P = [0.80, 0.82, 0.78]
CAND_P = [0.60, 0.62, 0.58]
CAND_RECALL = [0.50, 0.55, 0.45]  # the base's recall: [0.52, 0.47, 0.50]: noise


@pytest.fixture
def sides(tmp_path: Path) -> list[str]:
    args = []
    for i in range(3):
        b = write_summary(tmp_path / f"b{i}.parquet", precision=BASE_P[i], recall=0.52 - i / 40)
        c = write_summary(
            tmp_path / f"c{i}.parquet", precision=CAND_P[i], recall=CAND_RECALL[i], ate_m=0.3
        )
        args += ["-b", str(b), "-c", str(c)]
    return args


def test_json_carries_interval_test_p_values_and_n(sides, tmp_path) -> None:
    got = CliRunner().invoke(compare_command, [*sides, "--json"])
    assert got.exit_code == 1, got.output
    report = json.loads(got.output)  # nothing else on stdout
    assert report["regressed"] is True and report["regressions"] == ["precision"]
    assert report["inconclusive"] == ["recall"]
    assert report["alpha"] == 0.05 and report["interval_confidence"] == pytest.approx(0.9)
    (group,) = report["groups"]
    assert (group["key"], group["n_base"], group["n_candidate"]) == ({}, 3, 3)
    assert group["paired"] is False and group["open_loop"] is True
    assert group["input_damaged"] is False
    metrics = {m["metric"]: m for m in group["metrics"]}
    p = metrics["precision"]
    assert p["base"]["mean"] == pytest.approx(0.80) and p["candidate"]["mean"] == 0.60
    assert p["delta"] == pytest.approx(-0.2)
    assert p["tolerance"]["direction"] == "higher"
    assert p["tolerance"]["allowed"] == DEFAULT_TOLERANCES["precision"].absolute
    test = p["test"]
    assert test["name"] == "mann-whitney" and test["paired"] is False
    assert (test["n_base"], test["n_candidate"]) == (3, 3)
    # 3 a side: P(U ≤ 0) = 1/20 ≤ 0.05, so the interval's ends are the extreme differences
    diffs = sorted(c - b for b in BASE_P for c in CAND_P)
    assert test["interval"] == [pytest.approx(diffs[0]), pytest.approx(diffs[-1])]
    assert test["p_regression"] == pytest.approx(1 / 20)
    assert p["verdict"] == "regression" and p["regressed"] is True
    r = metrics["recall"]
    assert r["verdict"] == "inconclusive" and r["seeds_needed"] > 3
    assert "seeds a side needed" in r["reason"]
    ate = metrics["ate_m"]  # open loop: the log's figure
    assert ate["kind"] == "log" and ate["verdict"] == "-" and ate["test"] is None
    assert metrics["wall_s"]["kind"] == "wall-clock" and metrics["wall_s"]["tolerance"] is None


def test_json_to_a_file_and_the_table_on_stdout(sides, tmp_path) -> None:
    out = tmp_path / "gate.json"
    got = CliRunner().invoke(compare_command, [*sides, "--json", str(out)])
    assert got.exit_code == 1 and "regression beyond tolerance:\n  precision" in got.output
    assert json.loads(out.read_text())["regressions"] == ["precision"]
    dash = CliRunner().invoke(compare_command, [*sides, "--json", "-"])
    assert json.loads(dash.output)["regressed"] is True
    clash = CliRunner().invoke(compare_command, [*sides, "--json", sides[1]])
    assert clash.exit_code == 2 and "choose another --json" in clash.output


def test_junit_fails_regressions_and_skips_inconclusive(sides, tmp_path) -> None:
    out = tmp_path / "gate.xml"
    got = CliRunner().invoke(compare_command, [*sides, "--junit", str(out)])
    assert got.exit_code == 1 and "regression" in got.output
    root = ET.parse(out).getroot()
    (suite,) = root.findall("testsuite")
    cases = {c.get("name"): c for c in suite.findall("testcase")}
    assert int(suite.get("tests")) == len(cases) == int(root.get("tests"))
    failures = [name for name, c in cases.items() if c.find("failure") is not None]
    assert failures == ["precision"] and suite.get("failures") == "1"
    text = cases["precision"].find("failure").text
    assert "mann-whitney (unpaired, n=3/3)" in text and "90% interval" in text
    assert "p_regression 0.05" in text
    skipped = cases["recall"].find("skipped").get("message")
    assert skipped.startswith("inconclusive:") and "seeds a side needed (3 now)" in skipped
    assert "the log's" in cases["ate_m"].find("skipped").get("message")
    assert "wall-clock" in cases["wall_s"].find("skipped").get("message")


def test_no_regression_exits_0_in_both_forms(sides, tmp_path) -> None:
    bases = sides[1::4]
    args = [a for b in bases for a in ("-b", b, "-c", b)]
    out = tmp_path / "ok.xml"
    got = CliRunner().invoke(compare_command, [*args, "--json", "--junit", str(out)])
    assert got.exit_code == 0, got.output
    assert json.loads(got.output)["regressed"] is False
    assert ET.parse(out).getroot().get("failures") == "0"
