"""What the simulator's tests share: `flylog simulate` through the CLI, and a log's images as
raw messages (topic, log time, bytes) to compare bit for bit."""

from __future__ import annotations

from pathlib import Path

from click.testing import CliRunner, Result

from flylog.cli.main import cli
from flylog.io import contract
from flylog.io.reader import open_log


def image_messages(path: Path) -> list[tuple[str, int, bytes]]:
    """The log's left and right images, in log order."""
    return [
        (r.channel.topic, r.message.log_time, bytes(r.message.data))
        for r in open_log(path).raw_messages()
        if r.channel.topic in (contract.LEFT_IMAGE, contract.RIGHT_IMAGE)
    ]


def simulate_cli(scene: Path, out: Path, *args: str) -> Result:
    """``flylog simulate SCENE -o OUT ARGS...`` in process."""
    return CliRunner().invoke(cli, ["simulate", str(scene), "-o", str(out), *args])
