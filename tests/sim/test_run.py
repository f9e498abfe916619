"""The simulate loop and `flylog simulate`: rates, determinism, atomicity, errors, doctor."""

import shutil
import subprocess
from pathlib import Path

import numpy as np
import pytest
from click.testing import CliRunner

from flylog.cli.main import cli
from flylog.io import contract
from flylog.io.reader import open_log
from flylog.scene.load import load_scene
from flylog.sim.run import SimulationOptions, simulate

SCENES = Path(__file__).resolve().parents[2] / "fixtures" / "scenes"
SMALL = SimulationOptions(duration=1.0, seed=3, resolution=(64, 48))


def _messages(path):
    return [(m.topic, m.log_time_ns, m.raw) for m in _raw(path)]


def _raw(path):
    class R:
        def __init__(self, raw):
            self.topic, self.log_time_ns = raw.channel.topic, raw.message.log_time
            self.raw = bytes(raw.message.data)

    return [R(r) for r in open_log(path).raw_messages()]


@pytest.fixture(scope="module")
def corridor_log(tmp_path_factory):
    out = tmp_path_factory.mktemp("sim") / "corridor.mcap"
    summary = simulate(load_scene(SCENES / "corridor.toml"), out, SMALL)
    return out, summary


def test_each_sensor_keeps_its_own_rate(corridor_log):
    path, summary = corridor_log
    topics = open_log(path).topics()
    # 1 s at 15 Hz cameras, 10 Hz sonar, 50 Hz odometry, both ends included
    assert topics[contract.LEFT_IMAGE].count == 16 == summary.frames
    assert topics[contract.RIGHT_IMAGE].count == 16
    assert topics[contract.SONAR].count == 11
    assert topics[contract.ODOM].count == 51
    assert topics[contract.TRUTH_POSE].count == 51
    assert set(contract.TOPIC_SCHEMAS[t] for t in topics) >= {"foxglove.RawImage"}
    for topic, info in topics.items():
        assert info.schema == contract.TOPIC_SCHEMAS[topic]
    assert summary.messages == sum(i.count for i in topics.values())


def test_log_carries_scene_and_mission(corridor_log):
    path, _ = corridor_log
    reader = open_log(path)
    (attachment,) = reader.attachments()
    assert attachment.name == "scene.toml"
    assert attachment.data.decode() == (SCENES / "corridor.toml").read_text()
    meta = reader.metadata()[contract.SIMULATION_METADATA]
    assert meta["seed"] == "3" and meta["scene"] == "corridor"
    assert '"width": 64' in meta["camera"]


def test_true_and_odometric_poses_drift_apart_but_start_together(corridor_log):
    path, _ = corridor_log
    reader = open_log(path)
    odom = [m.value.pose for m in reader.messages([contract.ODOM])]
    true = [m.value.pose for m in reader.messages([contract.TRUTH_POSE])]
    assert odom[0] == true[0]
    gap = np.hypot(odom[-1].x - true[-1].x, odom[-1].y - true[-1].y)
    assert gap > 0.0
    assert odom[-1].x > odom[0].x  # the corridor plan drives forward


def test_same_seed_same_messages_other_seed_differs(corridor_log, tmp_path):
    path, _ = corridor_log
    again = tmp_path / "again.mcap"
    simulate(load_scene(SCENES / "corridor.toml"), again, SMALL)
    assert _messages(again) == _messages(path)
    other = tmp_path / "other.mcap"
    simulate(
        load_scene(SCENES / "corridor.toml"),
        other,
        SimulationOptions(duration=1.0, seed=4, resolution=(64, 48)),
    )
    assert _messages(other) != _messages(path)


@pytest.mark.skipif(
    shutil.which("pymcap-cli") is None and not Path(".venv/bin/pymcap-cli").exists(),
    reason="pymcap-cli not installed",
)
def test_log_passes_mcap_doctor(corridor_log):
    path, _ = corridor_log
    exe = shutil.which("pymcap-cli") or ".venv/bin/pymcap-cli"
    done = subprocess.run([exe, "doctor", str(path)], capture_output=True, text=True, check=False)
    assert done.returncode == 0, done.stdout + done.stderr
    assert "passed MCAP doctor checks" in done.stdout


def test_interrupted_simulation_leaves_no_file(tmp_path):
    out = tmp_path / "run.mcap"

    def interrupt(done, total):
        if done == 3:
            raise KeyboardInterrupt

    with pytest.raises(KeyboardInterrupt):
        simulate(load_scene(SCENES / "corridor.toml"), out, SMALL, on_frame=interrupt)
    assert list(tmp_path.iterdir()) == []


def test_cli_simulate_summary_line(tmp_path):
    out = tmp_path / "t.mcap"
    options = ["--duration", "0.5", "--resolution", "64x48", "--frame-rate", "10", "--seed", "1"]
    result = CliRunner().invoke(
        cli, ["simulate", str(SCENES / "turn.toml"), "-o", str(out), *options]
    )
    assert result.exit_code == 0, result.output
    assert "6 stereo frames" in result.output and "real time" in result.output
    assert open_log(out).topics()[contract.LEFT_IMAGE].count == 6


BOX_BELOW_GROUND = """name = "x"
[[obstacles]]
kind = "box"
center = [1, 0]
size = [1, 1]
height = -2
"""


@pytest.mark.parametrize(
    ("scene_text", "needle"),
    [
        (BOX_BELOW_GROUND, "field 'obstacles[0].height': must be at least"),
        ('name = "x"\n[camera]\nwidth = "wide"\n', "field 'camera.width': expected an integer"),
        (
            'name = "x"\n[[obstacles]]\nkind = "cone"\n',
            "field 'obstacles[0].kind': expected one of",
        ),
        ("name = [\n", "not valid TOML"),
    ],
)
def test_bad_scene_exit_2_names_file_and_field_and_writes_nothing(tmp_path, scene_text, needle):
    scene = tmp_path / "bad.toml"
    scene.write_text(scene_text)
    out = tmp_path / "out.mcap"
    result = CliRunner().invoke(cli, ["simulate", str(scene), "-o", str(out)])
    assert result.exit_code == 2
    assert str(scene) in result.output and needle in result.output
    assert not out.exists() and [p.name for p in tmp_path.iterdir()] == ["bad.toml"]


def test_cli_rejects_bad_resolution(tmp_path):
    out = tmp_path / "x.mcap"
    result = CliRunner().invoke(
        cli, ["simulate", str(SCENES / "turn.toml"), "-o", str(out), "--resolution", "big"]
    )
    assert result.exit_code == 2 and "WIDTHxHEIGHT" in result.output
