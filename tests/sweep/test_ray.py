"""The same tiny sweep as Ray tasks on a real local cluster of 2 CPUs: the same rows as the
process pool's, bit for bit, wall times aside."""

from __future__ import annotations

from pathlib import Path

from flylog.sweep.executors import Backend
from flylog.sweep.results import read_results
from flylog.sweep.runner import SweepOptions, SweepResult, run_sweep

from .test_sweep import timing_free


def test_ray_rows_equal_the_process_pools(
    pool_sweep: SweepResult, tiny_spec: Path, tmp_path: Path, monkeypatch
) -> None:
    monkeypatch.delenv("RAY_ADDRESS", raising=False)  # a new local cluster, whatever runs
    out = tmp_path / "sweep"
    got = run_sweep(tiny_spec, out, SweepOptions(Backend.RAY, workers=2))
    assert got.ran == 8 and got.reused == 0
    ray_rows = read_results(out)[1]
    pool_rows = read_results(pool_sweep.results)[1]
    assert [r["status"] for r in ray_rows] == ["ok"] * 4 + ["failed"] * 4
    assert timing_free(ray_rows) == timing_free(pool_rows)
    for r in ray_rows:
        assert (out / r["run_dir"]).is_dir()
