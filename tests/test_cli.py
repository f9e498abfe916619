"""The entry point: every command answers --help, and --help imports no heavy module."""

import subprocess
import sys
from pathlib import Path

import pytest
from click.testing import CliRunner

from flylog.cli.main import _COMMANDS, cli


@pytest.mark.parametrize("name", sorted(_COMMANDS))
def test_every_command_has_help_with_defaults(name):
    result = CliRunner().invoke(cli, [name, "--help"])
    assert result.exit_code == 0
    assert "Usage:" in result.output


def test_help_does_not_import_numba_or_mcap():
    code = (
        "import sys; from flylog.cli.main import cli\n"
        "for name in cli.list_commands(None): cli.get_command(None, name)\n"
        "heavy = [m for m in ('numba', 'mcap', 'cv2', 'pyarrow') if m in sys.modules]\n"
        "print(','.join(heavy))"
    )
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True)
    assert out.stdout.strip() == ""


@pytest.mark.parametrize("unit", ["s", "frames"])
def test_progress_bar_draws_on_a_terminal_before_and_after_the_first_update(unit):
    """On a terminal the bar is drawn as it starts, before any total is known: the None
    total formats, or every command run from a terminal would crash."""
    import io

    from rich.console import Console

    from flylog.cli.common import progress_bar

    out = io.StringIO()
    console = Console(file=out, force_terminal=True, width=100)
    with progress_bar("replay", unit, console=console) as update:
        update(1.5, 60.0)
    text = out.getvalue()
    assert "replay" in text
    assert ("1.5/60.0 s" if unit == "s" else "1/60") in text


def _imported_by(statement: str, modules: tuple[str, ...]) -> list[str]:
    """Which of ``modules`` a fresh interpreter has imported after ``statement``."""
    code = f"import sys\n{statement}\nprint(','.join(m for m in {modules!r} if m in sys.modules))"
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True)
    return [m for m in out.stdout.strip().split(",") if m]


METRICS_PATH = "import flylog.cli.metrics, flylog.metrics.score"


def test_metrics_imports_no_other_commands_library():
    """`flylog metrics` starts in well under a second: it imports neither the replay, the
    experiments, the planner, the renderer, opencv, matplotlib nor the writing side."""
    unneeded = (
        "flylog.replay", "flylog.experiments", "flylog.planner", "flylog.sim.render",
        "flylog.io.writer", "flylog.io.encode", "mcap.writer", "cv2", "matplotlib",
    )  # fmt: skip
    assert _imported_by(METRICS_PATH, unneeded) == []


def test_metrics_imports_neither_numba_nor_the_fly_engine():
    """numba's import alone is ~0.2 s of the metrics command, and nothing there is compiled."""
    assert _imported_by(METRICS_PATH, ("numba", "flylog.fly.engine")) == []


def test_progress_bar_off_a_terminal_draws_nothing_and_skips_rich_progress():
    statement = (
        "import io\nfrom rich.console import Console\n"
        "from flylog.cli.common import progress_bar\n"
        "out = io.StringIO()\n"
        "with progress_bar('metrics', 's', console=Console(file=out)) as update:\n"
        "    update(1.0, 2.0)\n"
        "assert out.getvalue() == ''"
    )
    assert _imported_by(statement, ("rich.progress", "flylog.cli.progress")) == []


def test_replay_leaves_its_imports_out_of_garbage_collection(tmp_path):
    """`flylog replay` freezes what its imports made (gc.freeze): full collections leave
    numba's registries out. In a fresh interpreter, as the command runs."""
    code = (
        "import gc, sys\n"
        "import flylog.cli.main as entry\n"
        "defaults = gc.get_threshold()\n"
        "entry.exit_at_once = lambda code: None  # to print what follows\n"
        "sys.argv = ['flylog', 'replay', 'missing.mcap', '-o', sys.argv[1]]\n"
        "entry.main()\n"
        "print(gc.get_freeze_count(), gc.get_threshold() == defaults)"
    )
    out = subprocess.run(
        [sys.executable, "-c", code, str(tmp_path / "run.mcap")],
        capture_output=True, text=True, check=True,
    )  # fmt: skip
    frozen, defaults = out.stdout.split()[-2:]
    assert int(frozen) > 50_000
    assert defaults == "True"  # collections as often as Python's defaults once imported
    assert "no such file" in out.stderr


def test_the_installed_command_flushes_its_output_and_keeps_its_exit_codes(tmp_path):
    """`flylog` ends without the interpreter's teardown (cli.main.exit_at_once): what it
    printed still arrives through a pipe, and the exit codes are click's and the
    commands' own."""
    flylog = Path(sys.executable).with_name("flylog")

    def run(*args: str) -> subprocess.CompletedProcess:
        return subprocess.run([flylog, *args], capture_output=True, text=True, check=False)

    version = run("--version")
    assert version.returncode == 0 and "version" in version.stdout
    missing = run("replay", str(tmp_path / "missing.mcap"), "-o", str(tmp_path / "run.mcap"))
    assert missing.returncode == 2 and "no such file" in missing.stderr
    bad = run("replay", "--no-such-option")
    assert bad.returncode == 2 and "No such option" in bad.stderr


def test_a_first_compilation_is_announced_and_a_cached_kernel_is_not(tmp_path):
    """progress_bar(kernels=True) prints one line at the first numba compilation in its
    block (the first run on a machine compiles for about a minute) and nothing when every
    kernel is already compiled."""
    code = (
        "import io, numba\n"
        "from rich.console import Console\n"
        "from flylog.cli.common import progress_bar\n"
        "@numba.njit\n"
        "def twice(x):\n"
        "    return 2 * x\n"
        "for attempt in range(2):\n"
        "    out = io.StringIO()\n"
        "    with progress_bar('replay', 's', console=Console(file=out), kernels=True):\n"
        "        twice(3)\n"
        "    print(repr(out.getvalue()))\n"
    )
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True)
    first, second = out.stdout.splitlines()
    assert "compiling flylog's numba kernels, first run only" in first
    assert second == "''"
