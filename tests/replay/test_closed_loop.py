"""`flylog simulate --drive planner`: the engine and planner drive the simulated robot."""

import json
from pathlib import Path

import numpy as np
from click.testing import CliRunner

from flylog.cli.main import cli
from flylog.io import contract
from flylog.io.reader import open_log

SCENES = Path(__file__).resolve().parents[2] / "fixtures" / "scenes"
ARGS = ["--duration", "2", "--resolution", "96x72", "--seed", "2", "--drive", "planner"]


def _run(tmp_path, name, extra=()):
    config = tmp_path / "loop.toml"
    config.write_text("[engine]\nflies = 600\n")
    out = tmp_path / name
    result = CliRunner().invoke(
        cli,
        [
            "simulate",
            str(SCENES / "corridor.toml"),
            "-o",
            str(out),
            *ARGS,
            "--config",
            str(config),
            *extra,
        ],
    )
    assert result.exit_code == 0, result.output
    return out


def test_closed_loop_log_carries_sensors_and_outputs_and_is_deterministic(tmp_path):
    a = _run(tmp_path, "a.mcap")
    reader = open_log(a)
    topics = reader.topics()
    for topic in (
        contract.LEFT_IMAGE,
        contract.TRUTH_POSE,
        contract.FLIES,
        contract.FLIES_OVERLAY,
        contract.PLANNER_POTENTIAL,
        contract.PLANNER_PATH,
        contract.PLANNER_COMMAND,
    ):
        assert topic in topics, topic
    meta = reader.metadata()[contract.REPLAY_METADATA]
    assert json.loads(meta["config"])["engine"]["flies"] == 600
    assert int(meta["generations"]) > 0
    # the robot follows the planner's commands: its odometry integrates them
    commands = [m.value for m in reader.messages([contract.PLANNER_COMMAND])]
    odom = [m.value.pose for m in reader.messages([contract.ODOM])]
    assert any(abs(c["linear"]) + abs(c["angular"]) > 0 for c in commands)
    moved = np.hypot(odom[-1].x - odom[0].x, odom[-1].y - odom[0].y)
    turned = abs(odom[-1].theta - odom[0].theta)
    assert moved + turned > 0.1
    b = _run(tmp_path, "b.mcap")
    raw = [
        [
            (r.channel.topic, r.message.log_time, bytes(r.message.data))
            for r in open_log(p).raw_messages()
        ]
        for p in (a, b)
    ]
    assert raw[0] == raw[1]


def test_config_without_closed_loop_is_refused(tmp_path):
    config = tmp_path / "loop.toml"
    config.write_text("seed = 1\n")
    result = CliRunner().invoke(
        cli,
        [
            "simulate",
            str(SCENES / "corridor.toml"),
            "-o",
            str(tmp_path / "x.mcap"),
            "--config",
            str(config),
        ],
    )
    assert result.exit_code == 2 and "--config goes with --drive planner" in result.output


def test_a_run_stuck_for_the_timeout_ends_with_its_status(tmp_path):
    # no progress can count (stuck_progress 100 m): STUCK from 0.5 s, over at 1.0 s of 4 s
    config = tmp_path / "stuck.toml"
    config.write_text(
        "[engine]\nflies = 600\n[planner]\nstuck_time = 0.5\nstuck_progress = 100.0\n"
        "stuck_timeout = 0.5\n"
    )
    out = tmp_path / "stuck.mcap"
    args = [
        "simulate",
        str(SCENES / "corridor.toml"),
        "-o",
        str(out),
        "--duration",
        "4",
        "--resolution",
        "96x72",
        "--drive",
        "planner",
        "--config",
        str(config),
    ]
    result = CliRunner().invoke(cli, args)
    assert result.exit_code == 0, result.output
    assert "planner stuck, run ended by stuck" in result.output
    reader = open_log(out)
    meta = reader.metadata()[contract.REPLAY_METADATA]
    assert meta["status"] == "stuck" and meta["ending"] == "stuck"
    assert float(meta["stuck_for"]) >= 0.5
    last = max(m.log_time_ns for m in reader.messages([contract.ODOM]))
    assert 1.0e9 <= last <= 1.2e9  # ended at the timeout, not at --duration
    statuses = [m.value["status"] for m in reader.messages([contract.PLANNER_COMMAND])]
    assert statuses[-1] == "stuck" and "driving" in statuses


def test_a_run_that_reaches_neither_goal_nor_timeout_ends_at_its_duration(tmp_path):
    out = _run(tmp_path, "short.mcap")
    meta = open_log(out).metadata()[contract.REPLAY_METADATA]
    assert meta["ending"] == "duration" and meta["status"] == "driving"


BOXED_IN = """
name = "boxed-in"
[robot]
start = [0.0, 0.0, 0.0]
goal = [3.0, 0.0]
""" + "".join(
    f'[[obstacles]]\nkind = "wall"\nstart = {list(a)}\nend = {list(b)}\n'
    for a, b in (
        ((-0.8, -0.8), (0.8, -0.8)),
        ((0.8, -0.8), (0.8, 0.8)),
        ((0.8, 0.8), (-0.8, 0.8)),
        ((-0.8, 0.8), (-0.8, -0.8)),
    )
)


def test_a_robot_walled_in_ends_unreachable(tmp_path):
    """The sonars hear the four walls round the robot; after the recoveries (a quick
    look-around here) the goal is still cut off: the run ends UNREACHABLE, not at its
    duration and not STUCK."""
    scene = tmp_path / "boxed.toml"
    scene.write_text(BOXED_IN)
    config = tmp_path / "quick.toml"
    config.write_text(
        "[engine]\nflies = 600\n[planner]\ncut_off_time = 0.3\nmax_angular_speed = 3.0\n"
    )
    out = tmp_path / "boxed.mcap"
    args = [
        "simulate",
        str(scene),
        "-o",
        str(out),
        "--duration",
        "8",
        "--resolution",
        "96x72",
        "--drive",
        "planner",
        "--config",
        str(config),
    ]
    result = CliRunner().invoke(cli, args)
    assert result.exit_code == 0, result.output
    assert "planner unreachable, run ended by unreachable" in result.output
    reader = open_log(out)
    meta = reader.metadata()[contract.REPLAY_METADATA]
    assert meta["status"] == "unreachable" and meta["ending"] == "unreachable"
    last = max(m.log_time_ns for m in reader.messages([contract.ODOM]))
    assert last < 7.0e9
