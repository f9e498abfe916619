"""``make demo``: the main job on the bundled default scene, as a user would run it.

Simulates the bundled scene ``corridor`` (``fixtures/scenes/corridor.toml``), replays the
log through the fly engine and the planner, scores the run against ground truth, prints the
summary and draws the run on one HTML page (``report.html``). Outputs go to the directory
given as the first argument (default ``demo-out``).
"""

from __future__ import annotations

import sys
from pathlib import Path

from flylog.cli.common import stdout
from flylog.cli.main import cli

SCENE = "corridor"  # bundled with flylog (flylog.scene.bundled)
DURATION = "10"


def main(argv: list[str]) -> int:
    out = Path(argv[0] if argv else "demo-out")
    out.mkdir(parents=True, exist_ok=True)
    log, run, metrics = out / "corridor.mcap", out / "run.mcap", out / "metrics.parquet"
    report = out / "report.html"
    steps = [
        ["simulate", SCENE, "-o", str(log), "--duration", DURATION, "--seed", "0"],
        ["replay", str(log), "-o", str(run), "--seed", "0"],
        ["metrics", str(run), "--log", str(log), "-o", str(metrics)],
        ["report", str(run), "--log", str(log), "-o", str(report)],
    ]
    for args in steps:
        stdout.print(f"[bold]$ flylog {' '.join(args)}[/]", soft_wrap=True)
        try:
            cli.main(args, standalone_mode=False)
        except SystemExit as exc:  # a command reported an error (already printed)
            return int(exc.code or 1)
    stdout.print(
        f"\nOpen {log} and {run} together in Foxglove (File → Open local file…) to see the "
        "images, the 3-D scene, the flies and the planner's potential.",
        soft_wrap=True,
    )
    stdout.print(
        f"The run's report (summary, map, frames with flies, curves, configuration): "
        f"{report.resolve()} — open it in a browser.",
        soft_wrap=True,
    )
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
