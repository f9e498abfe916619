"""Command-line reliability cases: a copy of a fixture log and scene in a working directory."""

from __future__ import annotations

import shutil
from pathlib import Path

import pytest
from click.testing import CliRunner

from flylog.cli.main import cli

ROOT = Path(__file__).resolve().parents[2]
LOG = ROOT / "fixtures" / "logs" / "turn.mcap"
SCENE = ROOT / "fixtures" / "scenes" / "turn.toml"


@pytest.fixture
def work(tmp_path, monkeypatch):
    """A directory holding log.mcap and s.toml, made the current directory."""
    shutil.copy(LOG, tmp_path / "log.mcap")
    shutil.copy(SCENE, tmp_path / "s.toml")
    monkeypatch.chdir(tmp_path)
    monkeypatch.delenv("FLYLOG_DEBUG", raising=False)
    return tmp_path


def run(*args: str, env: dict[str, str] | None = None):
    """``flylog ARGS`` in process; the result's ``stderr`` holds what the user sees."""
    return CliRunner().invoke(cli, list(args), env=env)


def error_lines(result) -> list[str]:
    return [line for line in result.stderr.splitlines() if line.strip()]
