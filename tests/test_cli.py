"""The entry point: every command answers --help, and --help imports no heavy module."""

import subprocess
import sys

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
    """On a terminal the bar is drawn as it starts, before any total is known (it once
    formatted that None total and crashed every command run from a terminal)."""
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
