"""What the simulator's tests share: `flylog simulate` through the CLI, a log's images as raw
messages (topic, log time, bytes) to compare bit for bit, and a tall textured post whose
vertical edges show a rolling shutter's lean."""

from __future__ import annotations

from pathlib import Path

from click.testing import CliRunner, Result

from flylog.cli.main import cli
from flylog.io import contract
from flylog.io.reader import open_log
from flylog.scene import parse_scene


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


POST = parse_scene(
    """
name = "post"
[[obstacles]]
kind = "box"
center = [3.2, 0.0]
size = [0.4, 0.4]
height = 10.0
texture = { feature_size = 0.04, contrast = 0.6 }
""",
    "mem",
)
