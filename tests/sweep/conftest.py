"""A tiny sweep shared by the sweep tests: one 1 s fixture log, two grid points, two seeds,
one generation per stereo pair (about 2 s a cell), plus a log that is no MCAP file (its
cells fail, the sweep goes on)."""

from __future__ import annotations

from pathlib import Path

import pytest

from flylog.sweep.runner import SweepOptions, SweepResult, run_sweep

LOGS = Path(__file__).resolve().parents[2] / "fixtures" / "logs"
NEAR = LOGS / "near-obstacle.mcap"

SPEC = """
logs = ["{log}", "bad.mcap"]
seeds = [0, 1]
[grid]
"engine.flies" = [96, 160]
[[variants]]
name = "per-frame"
generations_per_frame = 1
snapshot_rate = 15.0
"""


def write_spec(directory: Path, text: str, name: str = "spec.toml") -> Path:
    path = directory / name
    path.write_text(text, encoding="utf-8")
    return path


@pytest.fixture(scope="session")
def tiny_spec(tmp_path_factory: pytest.TempPathFactory) -> Path:
    directory = tmp_path_factory.mktemp("spec")
    (directory / "bad.mcap").write_text("not an MCAP file\n", encoding="utf-8")
    return write_spec(directory, SPEC.format(log=NEAR))


@pytest.fixture(scope="session")
def pool_sweep(tiny_spec: Path, tmp_path_factory: pytest.TempPathFactory) -> SweepResult:
    out = tmp_path_factory.mktemp("pool") / "sweep"
    return run_sweep(tiny_spec, out, SweepOptions(workers=2))
