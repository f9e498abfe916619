"""`flylog replay --engine sgbm`: the conventional pipeline on the same log, planner and
outputs as the flies, frame-synchronous on the virtual clock."""

import dataclasses
import json
import math
import re
from pathlib import Path

import numpy as np
import pyarrow.parquet as pq
import pytest
from click.testing import CliRunner

from flylog.baseline import SgbmConfig
from flylog.cli.main import cli
from flylog.config import from_mapping, replace_dotted
from flylog.errors import ConfigError
from flylog.io import contract
from flylog.io.reader import open_log
from flylog.metrics.score import score_run
from flylog.replay.clock import Mode
from flylog.replay.config import ReplayConfig, Stereo, load_replay_config
from flylog.replay.run import replay

LOGS = Path(__file__).resolve().parents[2] / "fixtures" / "logs"
CORRIDOR = LOGS / "corridor.mcap"  # 2 s, 160×120, 15 Hz
FLIES = from_mapping(type(ReplayConfig().engine), {"flies": 400}, source="test")
# 160 px wide images: 32 disparities reach down to 0.47 m and leave 128 columns matched
SGBM = ReplayConfig(stereo=Stereo.SGBM, engine=FLIES, sgbm=SgbmConfig(num_disparities=32))


def content(path):
    return [
        (r.channel.topic, r.message.log_time, bytes(r.message.data))
        for r in open_log(path).raw_messages()
    ]


@pytest.fixture(scope="module")
def sgbm_run(tmp_path_factory):
    return replay(CORRIDOR, tmp_path_factory.mktemp("sgbm") / "run.mcap", SGBM)


def test_sgbm_runs_sync_one_step_per_frame_at_its_configured_cost():
    assert SGBM.mode is Mode.SYNC and SGBM.generations_per_cycle == 1
    assert SGBM.generation_cost_ns(12345) == SGBM.sgbm.cost_ns
    flies = ReplayConfig(evals_per_second=1e6)
    assert flies.mode is Mode.ASYNC and flies.generation_cost_ns(5000) == 5_000_000


def test_writes_the_same_topics_as_the_flies(sgbm_run, tmp_path):
    flies = replay(CORRIDOR, tmp_path / "flies.mcap", ReplayConfig(engine=FLIES, sync=True))
    ours, theirs = open_log(sgbm_run.output).topics(), open_log(flies.output).topics()
    assert {t: (c.schema, c.count) for t, c in ours.items()} == {
        t: (c.schema, c.count) for t, c in theirs.items()
    }
    assert pq.read_table(sgbm_run.table).schema == pq.read_table(flies.table).schema
    # both are sync: the same frames are processed, one SGBM step each
    assert sgbm_run.frames == flies.frames == sgbm_run.generations
    # SGBM makes no fitness evaluations; the obstacle rule's distinctness test and the
    # heading's scan do (on its points as on flies), and nothing else
    paper_rule = replace_dotted(SGBM, {"obstacles.min_distinctness": 0.0, "heading.enabled": False})
    assert replay(CORRIDOR, tmp_path / "paper.mcap", paper_rule).evaluations == 0
    assert sgbm_run.evaluations > 0 and sgbm_run.stereo == "sgbm"


def test_cloud_carries_sgbm_points_in_base_link(sgbm_run):
    clouds = [m.value for m in open_log(sgbm_run.output).messages([contract.FLIES])]
    last = clouds[-1]
    assert 0 < len(last.xyz) <= FLIES.flies
    assert (last.fitness >= 1.0).all()
    # in front of the cameras, between the nearest depth 32 disparities reach and max_depth
    depth = last.xyz[:, 0] - 0.1
    f_b = 125.0 * 0.12
    assert depth.min() >= f_b / 32 - 1e-6 and depth.max() <= SGBM.sgbm.max_depth + 1e-6


def test_image_latency_is_a_frame_period_plus_the_cost(sgbm_run):
    latency = pq.read_table(sgbm_run.table).column("image_latency_s").to_pylist()
    seen = [x for x in latency if not math.isnan(x)]
    assert min(seen) >= 1 / 15 + SGBM.sgbm.seconds_per_frame - 1e-9


def test_a_slow_matcher_skips_frames(tmp_path):
    slow = dataclasses.replace(SGBM, sgbm=dataclasses.replace(SGBM.sgbm, seconds_per_frame=0.2))
    run = replay(CORRIDOR, tmp_path / "slow.mcap", slow)
    # 2 s of log at 0.2 s a frame: at most 11 frames matched; the newest complete one each time
    assert 8 <= run.generations <= 11 < run.frames
    latency = pq.read_table(run.table).column("image_latency_s").to_pylist()
    assert min(x for x in latency if not math.isnan(x)) >= 1 / 15 + 0.2 - 1e-9


def test_deterministic_and_reproducible_from_its_metadata(sgbm_run, tmp_path):
    meta = open_log(sgbm_run.output).metadata()[contract.REPLAY_METADATA]
    stored = from_mapping(ReplayConfig, json.loads(meta["config"]), source="metadata")
    assert stored == SGBM
    again = replay(CORRIDOR, tmp_path / "again.mcap", stored)
    assert content(again.output) == content(sgbm_run.output)


def test_metrics_score_the_sgbm_cloud(sgbm_run):
    result = score_run(sgbm_run.output, CORRIDOR)
    s = result.summary
    assert len(result.snapshots) == sgbm_run.snapshots - 1  # the first precedes any frame
    # measured 0.64 / 0.60 / 0.031 on this 160×120 log (400 points, 32 disparities); the far,
    # grazing walls' fine texture is averaged as a camera averages it, which leaves SGBM less
    # to match there than an aliased rendering would (recall 0.68)
    assert s["precision"] > 0.6 and s["recall"] > 0.55
    assert s["median_depth_error"] < 0.05


def test_config_file_selects_sgbm_and_refuses_several_steps_per_frame(tmp_path):
    good = tmp_path / "sgbm.toml"
    good.write_text('stereo = "sgbm"\n[sgbm]\nnum_disparities = 32\nseconds_per_frame = 0.03\n')
    config = load_replay_config(good)
    assert config.stereo is Stereo.SGBM and config.sgbm.cost_ns == 30_000_000
    bad = tmp_path / "bad.toml"
    bad.write_text('stereo = "sgbm"\ngenerations_per_frame = 3\n')
    with pytest.raises(ConfigError, match="sgbm processes each frame once"):
        load_replay_config(bad)
    typo = tmp_path / "typo.toml"
    typo.write_text('stereo = "sgm"\n')
    with pytest.raises(ConfigError, match="field 'stereo': expected one of 'flies', 'sgbm'"):
        load_replay_config(typo)


def test_cli_engine_option(tmp_path):
    config = tmp_path / "c.toml"
    config.write_text("generations_per_frame = 3\n[sgbm]\nnum_disparities = 32\n")
    out = tmp_path / "run.mcap"
    args = ["replay", str(CORRIDOR), "-o", str(out), "--config", str(config), "--flies", "300"]
    refused = CliRunner().invoke(cli, [*args, "--engine", "sgbm"])
    assert refused.exit_code == 2 and "generations_per_frame must be 0 or 1" in refused.output
    assert not out.exists()
    result = CliRunner().invoke(cli, [*args, "--engine", "sgbm", "--generations-per-frame", "1"])
    assert result.exit_code == 0, result.output
    assert "30 frames matched by SGBM" in result.output
    stored = json.loads(open_log(out).metadata()[contract.REPLAY_METADATA]["config"])
    assert (stored["stereo"], stored["sgbm"]["num_disparities"]) == ("sgbm", 32)
    cloud = next(iter(open_log(out).messages([contract.FLIES]))).value
    assert len(cloud.xyz) == 300
    text = re.sub(r"\s+", " ", CliRunner().invoke(cli, ["replay", "--help"]).output)
    assert "--engine [flies|sgbm]" in text
    assert f"[default: {ReplayConfig().stereo.value}]" in text


def test_closed_loop_drives_with_sgbm(tmp_path):
    config = tmp_path / "loop.toml"
    config.write_text(
        'stereo = "sgbm"\n[engine]\nflies = 600\n[sgbm]\nnum_disparities = 16\n'
        "[obstacles]\nmin_distinctness = 0.0\n[heading]\nenabled = false\n"  # no evaluations
    )
    out = tmp_path / "loop.mcap"
    scene = Path(__file__).resolve().parents[2] / "fixtures" / "scenes" / "corridor.toml"
    result = CliRunner().invoke(
        cli,
        ["simulate", str(scene), "-o", str(out), "--duration", "2", "--resolution", "96x72",
         "--seed", "2", "--drive", "planner", "--config", str(config)],
    )  # fmt: skip
    assert result.exit_code == 0, result.output
    reader = open_log(out)
    meta = reader.metadata()[contract.REPLAY_METADATA]
    assert json.loads(meta["config"])["stereo"] == "sgbm"
    assert int(meta["generations"]) > 0 and int(meta["evaluations"]) == 0
    clouds = [m.value for m in reader.messages([contract.FLIES])]
    assert any(len(c.xyz) > 0 for c in clouds)
    commands = [m.value for m in reader.messages([contract.PLANNER_COMMAND])]
    assert any(abs(c["linear"]) > 0 for c in commands)
    odom = [m.value.pose for m in reader.messages([contract.ODOM])]
    moved = np.hypot(odom[-1].x - odom[0].x, odom[-1].y - odom[0].y)
    assert moved + abs(odom[-1].theta - odom[0].theta) > 0.1
