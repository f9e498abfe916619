"""``flylog sweep --backend ray --address ADDR`` joins a Ray cluster already running: a head
of 2 CPUs started by another process (as on a real cluster), the tiny sweep run on it by
the command line in a process of its own, the same rows as the process pool's, the head
stopped after. Ray (2.52 on) authenticates with a token; head and client share one made
for the test (RAY_AUTH_MODE, RAY_AUTH_TOKEN), so nothing is read from or written to ~/.ray."""

from __future__ import annotations

import os
import secrets
import subprocess
import sys
from collections.abc import Iterator
from pathlib import Path

import pytest

from flylog.sweep.results import read_results
from flylog.sweep.runner import SweepResult

from .test_sweep import timing_free

pytest.importorskip("ray")

# The head's own process: starts a local cluster, prints its address, holds it until its
# stdin closes, then shuts it down (ray.shutdown stops the processes this driver started).
_HEAD = """
import sys
import ray
ray.init(num_cpus=2, include_dashboard=False, log_to_driver=False)
print(ray.get_runtime_context().gcs_address, flush=True)
sys.stdin.read()
ray.shutdown()
"""


@pytest.fixture
def ray_env() -> dict[str, str]:
    env = {k: v for k, v in os.environ.items() if k != "RAY_ADDRESS"}
    env.update(RAY_AUTH_MODE="token", RAY_AUTH_TOKEN=secrets.token_hex(16))
    return env


@pytest.fixture
def ray_head(ray_env: dict[str, str]) -> Iterator[str]:
    head = subprocess.Popen(
        [sys.executable, "-c", _HEAD],
        stdin=subprocess.PIPE,
        stdout=subprocess.PIPE,
        env=ray_env,
        text=True,
    )
    assert head.stdin is not None and head.stdout is not None
    try:
        address = head.stdout.readline().strip()
        assert address, f"the Ray head ended first (exit code {head.poll()})"
        yield address
    finally:
        head.stdin.close()
        try:
            head.wait(timeout=60)
        except subprocess.TimeoutExpired:
            head.kill()
            head.wait()


def test_address_joins_a_running_cluster_with_the_pools_rows(
    ray_head: str,
    ray_env: dict[str, str],
    pool_sweep: SweepResult,
    tiny_spec: Path,
    tmp_path: Path,
) -> None:
    out = tmp_path / "sweep"
    main = "from flylog.cli.main import main; main()"
    args = ["sweep", str(tiny_spec), "-o", str(out), "--backend", "ray", "--address", ray_head]
    command = [sys.executable, "-c", main, *args]
    got = subprocess.run(command, env=ray_env, capture_output=True, text=True, timeout=600)
    assert got.returncode == 1, got.stdout + got.stderr  # the bad log's cells fail
    assert "8 cells (8 run" in got.stdout, got.stdout
    ray_rows = read_results(out)[1]
    assert [r["status"] for r in ray_rows] == ["ok"] * 4 + ["failed"] * 4
    assert timing_free(ray_rows) == timing_free(read_results(pool_sweep.results)[1])
