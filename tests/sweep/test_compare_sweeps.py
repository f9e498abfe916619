from __future__ import annotations

import json
import xml.etree.ElementTree as ET
from pathlib import Path

import pyarrow as pa
import pyarrow.parquet as pq
from click.testing import CliRunner

from flylog.cli.main import cli
from flylog.sweep.compare import compare_results, input_damage
from flylog.sweep.results import read_results, results_columns, write_results
from flylog.sweep.runner import SweepResult

GRID = (("engine.flies", (100, 200)),)
INPUTS = ("a.mcap", "b.mcap")


def write_sweep(path: Path, precision, seeds=range(5), **extra) -> Path:
    """A hand-made results.parquet: every input × flies × seed, precision from
    ``precision(input, flies, seed)``, each cell ok."""
    rows = []
    for inp in INPUTS:
        for flies in (100, 200):
            for seed in seeds:
                row = {c.name: None for c in results_columns(GRID)}
                row.update(
                    cell=len(rows),
                    input=inp,
                    input_kind="log",
                    seed=seed,
                    variant="default",
                    status="ok",
                    run_dir=f"runs/{len(rows)}",
                    fingerprint="x",
                    precision=precision(inp, flies, seed),
                    **{"engine.flies": flies},
                )
                rows.append(row)
    path.mkdir(parents=True, exist_ok=True)
    write_results(path / "results.parquet", GRID, rows, path / "spec.toml")
    if extra:  # columns set per input and seed: replaced where the sweep writes them
        table = pq.read_table(path / "results.parquet")
        for name, value in extra.items():
            column = pa.array(
                [value(r["input"], r["seed"]) for r in rows],
                type=table.schema.field(name).type if name in table.column_names else None,
            )
            if name in table.column_names:
                table = table.set_column(table.column_names.index(name), name, column)
            else:
                table = table.append_column(name, column)
        pq.write_table(table, path / "results.parquet")
    return path


def noise(inp: str, flies: int, seed: int) -> float:
    """Precision that differs much between inputs and a little between seeds."""
    return (0.9 if inp == "a.mcap" else 0.6) + 0.01 * ((seed * 7) % 5 - 2)


def test_cells_are_matched_by_grid_point_and_input_and_paired_by_seed(tmp_path) -> None:
    base = write_sweep(tmp_path / "base", noise)
    worse = write_sweep(
        tmp_path / "cand", lambda i, f, s: noise(i, f, s) - (0.05 if f == 200 else 0.0)
    )
    got = compare_results(base, worse)
    keys = [g.key for g in got.groups]
    assert keys == [
        (("variant", "default"), ("engine.flies", f), ("input", i))
        for i in INPUTS
        for f in (100, 200)
    ]
    for g in got.groups:
        assert g.comparison.paired and g.comparison.n_base == 5
        (p,) = [m for m in g.comparison.metrics if m.name == "precision"]
        flies = dict(g.key)["engine.flies"]
        # paired by seed, each pair's difference is exactly the shift: 0 or −0.05
        assert p.judgement.shift.high == p.judgement.shift.low
        assert p.verdict.value == ("regression" if flies == 200 else "no change")


def test_disjoint_seeds_compare_unpaired(tmp_path) -> None:
    base = write_sweep(tmp_path / "base", noise)
    other = write_sweep(tmp_path / "cand", noise, seeds=range(5, 10))
    got = compare_results(base, other)
    assert not any(g.comparison.paired for g in got.groups)
    test = got.groups[0].comparison.metrics
    assert {m.judgement.shift.test for m in test if m.judgement.shift} == {"mann-whitney"}
    assert not any(g.comparison.regressed for g in got.groups)


def test_damaged_inputs_are_named_in_every_output(tmp_path) -> None:
    base = write_sweep(tmp_path / "base", noise)
    damaged = write_sweep(
        tmp_path / "cand",
        noise,
        input_messages_lost=lambda inp, seed: 3 if inp == "b.mcap" and seed == 0 else 0,
        input_warnings=lambda inp, seed: "chunk 2: CRC mismatch" if inp == "b.mcap" else "",
    )
    got = compare_results(base, damaged)
    by_input = {dict(g.key)["input"]: g for g in got.groups}
    assert by_input["a.mcap"].input_damage == ()
    assert by_input["b.mcap"].input_damage == (
        "candidate: 3 input messages lost in 1 of 5 cells",
        "candidate: input warning: chunk 2: CRC mismatch",
    )
    out = tmp_path / "gate.xml"
    runner = CliRunner()
    got = runner.invoke(cli, ["compare", str(base), str(damaged), "--json", "--junit", str(out)])
    report = json.loads(got.stdout)
    damaged_groups = [g for g in report["groups"] if g["input_damaged"]]
    assert {g["key"]["input"] for g in damaged_groups} == {"b.mcap"}
    assert "CRC mismatch" in damaged_groups[0]["input_damage"][1]
    suites = ET.parse(out).getroot().findall("testsuite")
    props = [s.find("properties/property") for s in suites]
    assert sum(p is not None for p in props) == 2 and "3 input messages lost" in str(
        [p.get("value") for p in props if p is not None]
    )
    table = runner.invoke(cli, ["compare", str(base), str(damaged)], env={"COLUMNS": "80"})
    assert "input damaged: candidate: 3 input messages lost" in table.stdout
    assert input_damage("base", [{"seed": 0}]) == []  # the columns absent: nothing to say


def test_cli_json_of_two_sweeps(tmp_path) -> None:
    base = write_sweep(tmp_path / "base", noise)
    worse = write_sweep(tmp_path / "cand", lambda i, f, s: noise(i, f, s) - 0.1 * (f == 200))
    got = CliRunner().invoke(cli, ["compare", str(base), str(worse), "--json"])
    assert got.exit_code == 1
    report = json.loads(got.stdout)
    assert report["regressions"] == [
        f"variant=default, engine.flies=200, input={i}: precision" for i in INPUTS
    ]
    table = CliRunner().invoke(cli, ["compare", str(base), str(worse)], env={"COLUMNS": "80"})
    assert table.exit_code == 1
    assert max(len(line) for line in table.stdout.splitlines()) <= 80
    assert "paired by seed" in table.stdout


def test_a_real_sweep_against_itself(pool_sweep: SweepResult, tmp_path: Path) -> None:
    got = compare_results(pool_sweep.results, pool_sweep.results)
    # the log that is no MCAP file failed everywhere: its cells leave no group
    assert [dict(g.key)["engine.flies"] for g in got.groups] == [96, 160]
    for g in got.groups:
        assert g.comparison.paired and g.failed_base == 0 and not g.comparison.regressed
        names = {m.name for m in g.comparison.metrics}
        assert "seed" not in names and "cell" not in names and "f_score" in names
    _, rows = read_results(pool_sweep.results)
    assert {r["seed"] for r in rows} == {0, 1}
