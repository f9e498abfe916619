"""Every command of README.md (and of docs/datasets.md's tour), run as a new user runs
them: block after block, in one directory a page (the checkout's ``fixtures/`` beside them,
as from the checkout's root), each with the exit code the page gives it (0 unless a
``# exits 1`` or ``# exits 0 or 1`` comment says otherwise).

Commands run in this process (click's runner), so the numba kernels load once. Logs are
shorter than the README's (``FASTER``): the options are the README's, only the amounts
differ. The dataset the pages import (``Motorcycle-perfect/``, ``Motorcycle/``) is the
Middlebury 2014 Motorcycle pair at the quarter size scikit-image ships, written in its layout.
"""

from __future__ import annotations

import re
import shlex
from dataclasses import dataclass
from pathlib import Path

import pytest
from click.testing import CliRunner

from flylog.cli.main import cli

ROOT = Path(__file__).resolve().parents[1]
README = ROOT / "README.md"
# Pages whose commands run, and the dataset folders each one imports.
PAGES = {README: ("Motorcycle-perfect",), ROOT / "docs" / "datasets.md": ("Motorcycle",)}

# Appended to a command's arguments (click keeps an option's last value): short logs at
# 160x120, one seed.
FASTER = {
    "simulate": ["--duration", "1", "--resolution", "160x120"],
    "experiment": ["--duration", "0.5", "--seeds", "1"],
}
_EXITS = re.compile(r"#.*\bexits ([01])(?: or ([01]))?\b")
_BLOCK = re.compile(r"^```sh\n(.*?)^```", re.S | re.M)


@dataclass(frozen=True)
class Command:
    line: int  # README.md's line number
    args: tuple[str, ...]  # after `flylog`
    exits: frozenset[int]

    def __str__(self) -> str:
        return f"README.md:{self.line}: flylog {shlex.join(self.args)}"


def readme_commands(text: str) -> list[Command]:
    """The ``flylog`` commands of the ``sh`` blocks, in order (``a && b`` is two); lines
    running ``make`` are left out (the Makefile's targets run them)."""
    found = []
    for block in _BLOCK.finditer(text):
        first = text.count("\n", 0, block.start(1)) + 1
        for i, raw in enumerate(block.group(1).splitlines()):
            words = shlex.split(raw, comments=True)
            if not words or words[0] == "make":
                continue
            m = _EXITS.search(raw)
            exits = frozenset(int(g) for g in m.groups() if g) if m else frozenset({0})
            command: list[str] = []
            for word in [*words, "&&"]:
                if word != "&&":
                    command.append(word)
                    continue
                assert command[0] == "flylog", f"README.md:{first + i}: {raw!r} is not flylog"
                found.append(Command(first + i, tuple(command[1:]), exits))
                command = []
    return found


def test_the_readme_commands_are_found() -> None:
    commands = readme_commands(README.read_text(encoding="utf-8"))
    names = {c.args[0] for c in commands}
    assert {"simulate", "replay", "metrics", "compare", "report", "export"} <= names
    assert {"import", "sweep", "experiment"} <= names
    assert any(c.exits == {0, 1} for c in commands)  # a gate whose verdict may be either


def _motorcycle(folder: Path) -> None:
    from tests.datasets.test_motorcycle import write_motorcycle

    write_motorcycle(folder)


def _run_page(page: Path, here: Path, datasets: tuple[str, ...], monkeypatch) -> None:
    here.mkdir()
    (here / "fixtures").symlink_to(ROOT / "fixtures", target_is_directory=True)
    for folder in datasets:
        _motorcycle(here / folder)
    monkeypatch.chdir(here)
    runner = CliRunner()
    for command in readme_commands(page.read_text(encoding="utf-8")):
        args = [*command.args, *FASTER.get(command.args[0], [])]
        got = runner.invoke(cli, args)
        assert got.exit_code in command.exits, (
            f"{page.name}: {command} exited {got.exit_code}, the page says "
            f"{sorted(command.exits)}:\n{got.output[-2000:]}"
        )


@pytest.mark.slow
def test_every_readme_command_runs_as_written(tmp_path: Path, monkeypatch) -> None:
    pytest.importorskip("skimage")
    for page, datasets in PAGES.items():
        _run_page(page, tmp_path / page.stem, datasets, monkeypatch)
    here = tmp_path / README.stem
    # The outputs the README names where no -o does.
    outputs = (
        "run.metrics.parquet",
        "run.html",
        "loop.metrics.parquet",
        "moto-run.metrics.parquet",
        "moto-run.html",
        "sweep-out/report.html",
        "gate.xml",
        "experiments-out/latency/summary.md",
    )
    for made in outputs:
        assert (here / made).is_file(), made
