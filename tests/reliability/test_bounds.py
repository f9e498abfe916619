"""Every figure is bounded before work starts: ranges, rates against the camera, and the
estimated output size and memory against limits; scene files that cannot be driven."""

from __future__ import annotations

import dataclasses

import pytest

from flylog.budget import Limits, simulation_estimate
from flylog.errors import ConfigError, LimitError
from flylog.geometry import StereoRig
from flylog.replay.config import ReplayConfig
from flylog.replay.estimate import replay_estimate
from flylog.scene.load import parse_scene
from tests.reliability.conftest import error_lines, run

REFUSED = [
    (
        ["simulate", "s.toml", "-o", "x.mcap", "--duration", "1e9"],
        "a 1e+09 s simulation would write about",
        "--max-output-size sets the limit",
    ),
    (
        [
            "simulate",
            "s.toml",
            "-o",
            "x.mcap",
            "--resolution",
            "8192x8192",
            "--duration",
            "0.1",
            "--max-memory",
            "1G",
        ],
        "would need about 1.79 GiB of memory, over the limit of 1 GiB",
        "--max-memory sets",
    ),
    (
        ["replay", "log.mcap", "-o", "r.mcap", "--snapshot-rate", "1e12"],
        "'--snapshot-rate': 1000000000000.0 is not in the range 0.01<=x<=10000.0",
        "",
    ),
    (
        ["replay", "log.mcap", "-o", "r.mcap", "--snapshot-rate", "1000"],
        "snapshot_rate = 1000 Hz is above 150 Hz, 10 times the camera's frame rate in the log "
        "log.mcap (15 Hz)",
        "(option --snapshot-rate)",
    ),
    (
        ["replay", "log.mcap", "-o", "r.mcap", "--flies", "20000000"],
        "'--flies': 20000000 is not in the range 16<=x<=10000000",
        "",
    ),
    (
        ["replay", "log.mcap", "-o", "r.mcap", "--config", "extent.toml"],
        "a replay of 2 s would write about",
        "--max-output-size sets the limit",
    ),
    (
        [
            "replay",
            "log.mcap",
            "-o",
            "r.mcap",
            "--config",
            "extent.toml",
            "--max-output-size",
            "1P",
        ],
        "expected a size such as 500M",
        "'--max-output-size'",
    ),
    (
        ["replay", "log.mcap", "-o", "r.mcap", "--config", "tick.toml"],
        "planner.tick_rate = 1000 Hz is above 150 Hz",
        "(15 Hz)",
    ),
    (
        ["simulate", "s.toml", "-o", "x.mcap", "--drive", "planner", "--config", "tick.toml"],
        "planner.tick_rate = 1000 Hz is above 150 Hz",
        "in the scene s.toml (15 Hz)",
    ),
    (
        ["simulate", "s.toml", "-o", "x.mcap", "--frame-rate", "1e9"],
        "'--frame-rate': 1000000000.0 is not in the range 0.1<=x<=1000.0",
        "",
    ),
    (
        ["simulate", "s.toml", "-o", "x.mcap", "--resolution", "99999x99999"],
        "image sides must be 16 to 8192 pixels, got '99999x99999'",
        "",
    ),
]


@pytest.mark.parametrize(("args", "start", "end"), REFUSED)
def test_runaway_jobs_are_refused_before_they_start(work, args, start, end):
    (work / "extent.toml").write_text("[planner]\nextent = 1e6\n")
    (work / "tick.toml").write_text("[planner]\ntick_rate = 1000.0\n")
    result = run(*args)
    assert result.exit_code == 2
    text = " ".join(error_lines(result))
    assert start in text and end in text, text
    assert not list(work.glob("*.mcap*")) or sorted(p.name for p in work.glob("*.mcap")) == [
        "log.mcap"
    ]
    assert not list(work.glob(".*.part"))


def test_the_limits_lift_a_refusal(work):
    """A 0.07 s log of 16x16 images is estimated at about 39 KiB: refused under a 1 KiB
    limit, written under 1 MiB."""
    args = ["simulate", "s.toml", "-o", "x.mcap", "--resolution", "16x16", "--duration", "0.07"]
    result = run(*args, "--max-output-size", "1K")
    assert result.exit_code == 2 and "over the limit of 1 KiB on outputs" in result.stderr
    result = run(*args, "--max-output-size", "1M")
    assert result.exit_code == 0, result.output
    assert (work / "x.mcap").is_file()


def test_the_output_estimate_bounds_the_uncompressed_log(work):
    """Uncompressed, the images are the log: the estimate is at least its size and within
    25 % above it (turn.toml, 0.5 s at 64x48)."""
    result = run(
        "simulate",
        "s.toml",
        "-o",
        "x.mcap",
        "--duration",
        "0.5",
        "--resolution",
        "64x48",
        "--compression",
        "none",
    )
    assert result.exit_code == 0, result.output
    size = (work / "x.mcap").stat().st_size
    rig = StereoRig(width=64, height=48, focal_px=500.0 * 64 / 640)
    estimate = simulation_estimate(rig, 0.5, sonar_rate=10.0, odometry_rate=50.0)
    assert size <= estimate.output_bytes <= 1.25 * size


def test_replay_estimate_grows_with_the_grid_and_the_snapshots():
    rig = StereoRig()
    base = replay_estimate(ReplayConfig(), rig, 60.0)
    planner = dataclasses.replace(ReplayConfig().planner, extent=200.0)
    wide = replay_estimate(dataclasses.replace(ReplayConfig(), planner=planner), rig, 60.0)
    # 2000² instead of 200² cells: 100x the potential per snapshot, 160 B a cell of memory
    assert wide.memory_bytes - base.memory_bytes == 160 * (2000**2 - 200**2)
    assert wide.output_bytes > 40 * base.output_bytes
    with pytest.raises(LimitError) as info:
        wide.check(Limits(max_output_size=2**30, max_memory=2**40))
    assert info.value.parameter == "max_output_size"


SCENE_ERRORS = [
    (
        'name = "s"\n[camera]\nbaseline = 0.0\n',
        "s.toml: field 'camera.baseline': must be at least 0.001 m, got 0.0",
    ),
    (
        'name = "s"\n[[obstacles]]\nkind = "box"\ncenter = [0.2, 0.0]\nsize = [0.5, 0.5]\n',
        "s.toml: obstacles[0] lies over the robot's start [0.0, 0.0] (closer than robot.radius "
        "= 0.3 m): move it or 'robot.start'",
    ),
    (
        'name = "s"\n[robot]\ngoal = [5.0, 0.0]\n[[obstacles]]\nkind = "cylinder"\n'
        "center = [5.1, 0.0]\nradius = 0.5\n",
        "s.toml: field 'robot.goal': [5.0, 0.0] is inside obstacles[0]: move the goal",
    ),
    (
        'name = "s"\n[robot]\ngoal = [nan, 0.0]\n',
        "s.toml: field 'robot.goal[0]': expected a finite number, got nan",
    ),
    (
        'name = "s"\n[lighting]\nazimuth_deg = inf\n',
        "s.toml: field 'lighting.azimuth_deg': expected a finite number, got inf",
    ),
    (
        'name = "s"\nduration = -1.0\n[camera]\nbaseline = 0.0\nwidth = 9\n[robot]\nradius = nan\n',
        "s.toml: 4 problems: field 'duration': must be at least 0.0 s, got -1.0; field "
        "'camera.baseline': must be at least 0.001 m, got 0.0; field 'camera.width': must be at "
        "least 16 px, got 9; field 'robot.radius': expected a finite number, got nan",
    ),
    (
        'name = "s"\n[robot]\ngoal = [5.0, 0.0]\n[[obstacles]]\nkind = "cylinder"\n'
        'center = [0.0, 0.0]\nradius = 0.5\n[[obstacles]]\nkind = "wall"\nstart = [5.0, -1.0]\n'
        "end = [5.0, 1.0]\n",
        "s.toml: 2 problems: obstacles[0] lies over the robot's start",
    ),
]


def test_command_line_overrides_are_checked_as_a_file_is():
    from flylog.config import replace_dotted

    config = replace_dotted(ReplayConfig(), {"engine.flies": 6000, "snapshot_rate": 2.0})
    assert (config.engine.flies, config.snapshot_rate) == (6000, 2.0)
    with pytest.raises(ConfigError, match=r"'engine.flies': must be at most 10000000") as info:
        replace_dotted(ReplayConfig(), {"engine.flies": 10**12})
    assert info.value.parameter == "engine.flies"
    with pytest.raises(ConfigError, match="'evals_per_second' must be a finite number, got nan"):
        replace_dotted(ReplayConfig(), {"evals_per_second": float("nan")})


@pytest.mark.parametrize(("text", "message"), SCENE_ERRORS)
def test_scene_files_that_cannot_be_driven_are_errors(text, message):
    with pytest.raises(ConfigError) as info:
        parse_scene(text, "s.toml")
    assert str(info.value).startswith(message), str(info.value)


def test_an_unbounded_finite_option_says_finite_in_its_help():
    from flylog.cli.common import Finite

    assert Finite()._describe_range() == "finite"
    assert Finite(min=0.1)._describe_range() == "x>=0.1"
    text = run("simulate", "--help").output
    assert "x<=None" not in text and "[finite]" in text
