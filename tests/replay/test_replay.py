"""`flylog replay` on the fixture logs: outputs, determinism, truth-blindness, errors."""

import dataclasses
import json
import os
import re
import sys
import threading
from pathlib import Path

import numpy as np
import pyarrow.parquet as pq
import pytest
from click.testing import CliRunner

from flylog.cli.main import cli
from flylog.config import from_mapping, replace_dotted
from flylog.io import contract
from flylog.io.fingerprint import log_fingerprint
from flylog.io.reader import open_log
from flylog.replay.config import ReplayConfig
from flylog.replay.run import replay
from tests.logcopy import copy_log

LOGS = Path(__file__).resolve().parents[2] / "fixtures" / "logs"
CORRIDOR = LOGS / "corridor.mcap"
SMALL = ReplayConfig(
    engine=from_mapping(type(ReplayConfig().engine), {"flies": 400}, source="test"),
    generations_per_frame=2,
)


def table_rows(path):
    """Rows with NaN made comparable (NaN != NaN would hide real equality)."""
    rows = pq.read_table(path).to_pylist()
    return [{k: ("nan" if v != v else v) for k, v in row.items()} for row in rows]


def content(path):
    return [
        (r.channel.topic, r.message.log_time, bytes(r.message.data))
        for r in open_log(path).raw_messages()
    ]


@pytest.fixture(scope="module")
def corridor_run(tmp_path_factory):
    out = tmp_path_factory.mktemp("replay") / "run.mcap"
    return replay(CORRIDOR, out, SMALL)


def test_writes_every_output_topic_and_one_row_per_planner_tick(corridor_run):
    reader = open_log(corridor_run.output)
    topics = reader.topics()
    for topic in (
        contract.FLIES,
        contract.FLIES_OVERLAY,
        contract.PLANNER_POTENTIAL,
        contract.PLANNER_PATH,
        contract.PLANNER_COMMAND,
        contract.TF,
    ):
        assert topics[topic].schema == contract.TOPIC_SCHEMAS[topic]
    # 2 s of log: planner at 10 Hz and snapshots at 5 Hz, both ends included
    assert topics[contract.PLANNER_COMMAND].count == 21
    assert topics[contract.PLANNER_POTENTIAL].count == 11 == corridor_run.snapshots
    table = pq.read_table(corridor_run.table)
    assert table.num_rows == 21
    assert table.column("t_s").to_pylist()[:3] == pytest.approx([0.0, 0.1, 0.2])
    cloud = next(iter(reader.messages([contract.FLIES]))).value
    assert cloud.xyz.shape == (400, 3)


def test_per_frame_mode_runs_exactly_n_generations_per_frame(corridor_run):
    assert corridor_run.frames == 31
    assert corridor_run.generations == 62


def test_effective_config_is_stored_and_reproduces_the_run(corridor_run, tmp_path):
    meta = open_log(corridor_run.output).metadata()[contract.REPLAY_METADATA]
    stored = from_mapping(ReplayConfig, json.loads(meta["config"]), source="metadata")
    assert stored == SMALL
    assert meta["log_fingerprint"] == log_fingerprint(CORRIDOR)  # metrics checks --log by it
    again = replay(CORRIDOR, tmp_path / "again.mcap", stored)
    assert content(again.output) == content(corridor_run.output)
    assert table_rows(again.table) == table_rows(corridor_run.table)


def test_never_reads_truth(corridor_run, tmp_path):
    blind = tmp_path / "no-truth.mcap"
    copy_log(
        CORRIDOR,
        blind,
        topics=lambda topic: not topic.startswith(contract.TRUTH_PREFIX),
        metadata=lambda records: {
            name: values
            for name, values in records.items()
            if name != contract.TRAJECTORIES_METADATA
        },
        attachments=False,  # the scene file is ground truth too
    )
    assert not any(t.startswith("/truth/") for t in open_log(blind).topics())
    assert contract.TRAJECTORIES_METADATA in open_log(CORRIDOR).metadata()
    assert contract.TRAJECTORIES_METADATA not in open_log(blind).metadata()
    run = replay(blind, tmp_path / "run.mcap", SMALL)
    assert content(run.output) == content(corridor_run.output)


def test_sync_sees_images_at_least_one_frame_late_async_sooner(tmp_path):
    sync = replay(
        CORRIDOR,
        tmp_path / "s.mcap",
        ReplayConfig(engine=SMALL.engine, sync=True, generations_per_frame=1),
    )
    asyn = replay(CORRIDOR, tmp_path / "a.mcap", ReplayConfig(engine=SMALL.engine))
    lat_sync = pq.read_table(sync.table).column("image_latency_s").to_pylist()[5:]
    lat_async = pq.read_table(asyn.table).column("image_latency_s").to_pylist()[5:]
    period = 1 / 15
    assert min(lat_sync) >= period - 1e-9
    assert sorted(lat_async)[len(lat_async) // 2] < sorted(lat_sync)[len(lat_sync) // 2]


def test_interrupted_replay_leaves_neither_output(tmp_path):
    out = tmp_path / "run.mcap"

    def stop(done, total):
        if done > 0.5:
            raise KeyboardInterrupt

    with pytest.raises(KeyboardInterrupt):
        replay(CORRIDOR, out, SMALL, on_progress=stop)
    assert list(tmp_path.iterdir()) == []


def test_cli_config_file_and_overrides(tmp_path):
    config = tmp_path / "replay.toml"
    config.write_text("seed = 7\ngenerations_per_frame = 3\n[engine]\nflies = 300\n")
    out = tmp_path / "run.mcap"
    result = CliRunner().invoke(
        cli,
        [
            "replay",
            str(CORRIDOR),
            "-o",
            str(out),
            "--config",
            str(config),
            "--generations-per-frame",
            "1",
        ],
    )
    assert result.exit_code == 0, result.output
    assert "31 generations" in result.output
    stored = json.loads(open_log(out).metadata()[contract.REPLAY_METADATA]["config"])
    assert (stored["seed"], stored["generations_per_frame"], stored["engine"]["flies"]) == (
        7,
        1,
        300,
    )


@pytest.mark.parametrize(
    ("make", "needle"),
    [
        (lambda p: p.write_text("not a log"), "is not an MCAP file"),
        (lambda p: None, "no such file"),
    ],
)
def test_cli_bad_log_exit_2_and_no_output(tmp_path, make, needle):
    log = tmp_path / "bad.mcap"
    make(log)
    out = tmp_path / "run.mcap"
    result = CliRunner().invoke(cli, ["replay", str(log), "-o", str(out)])
    assert result.exit_code == 2
    assert needle in result.output and str(log) in result.output
    assert not out.exists() and not out.with_suffix(".parquet").exists()


def test_cli_log_without_images_names_missing_and_present_topics(tmp_path):
    log = tmp_path / "odom-only.mcap"
    copy_log(CORRIDOR, log, topics=lambda topic: topic == contract.ODOM, attachments=False)
    result = CliRunner().invoke(cli, ["replay", str(log), "-o", str(tmp_path / "r.mcap")])
    assert result.exit_code == 2
    assert "lacks topic(s) /camera/left/image" in result.output
    assert "the topics present are: /odom (foxglove.PoseInFrame)" in result.output


def test_cli_truncated_log_is_replayed_with_a_warning(tmp_path):
    chunked = tmp_path / "chunked.mcap"  # small chunks, so a cut keeps most of the log
    copy_log(CORRIDOR, chunked, attachments=False, chunk_size=64 * 1024)
    cut = tmp_path / "cut.mcap"
    cut.write_bytes(chunked.read_bytes()[: chunked.stat().st_size * 2 // 3])
    out = tmp_path / "run.mcap"
    result = CliRunner().invoke(
        cli, ["replay", str(cut), "-o", str(out), "--flies", "300", "--generations-per-frame", "1"]
    )
    assert result.exit_code == 0, result.output
    assert "truncated or unfinished" in result.output and "recovered" in result.output
    assert out.exists()


def test_help_defaults_match_the_configuration():
    text = CliRunner().invoke(cli, ["replay", "--help"]).output
    text = re.sub(r"\s+", " ", text)
    cfg = ReplayConfig()
    assert f"[default: {cfg.seed}]" in text
    assert f"[default: {cfg.engine.flies}]" in text
    assert f"[default: {cfg.generations_per_frame}]" in text
    assert f"[default: {cfg.evals_per_second:.0f} evaluations/s]" in text
    assert f"[default: {cfg.snapshot_rate:g} Hz]" in text


def _pipeline_outputs(
    planner_thread: bool, config: ReplayConfig = SMALL, *, copy_at_publish: bool = False
) -> tuple[list, list]:
    """Every message and table row of a replay of CORRIDOR, run through the pipeline
    (``copy_at_publish``: the plain way, copying the population at each publish, and the
    clock never saying that no tick can read it)."""
    from flylog.io.pairing import pair_stereo
    from flylog.replay.clock import VirtualClock
    from flylog.replay.pipeline import FlyPipeline
    from flylog.replay.run import clock_config
    from flylog.sources.inputs import SENSOR_TOPICS, replay_inputs

    class CopyAtPublish(FlyPipeline):
        def publish(self, t_ns: int) -> None:
            super().publish(t_ns)
            self.published.population()  # the copy made now, not when first read

    reader = open_log(CORRIDOR)
    inputs = replay_inputs(reader, goal=None)
    written, rows = [], []

    def write(topic, t_ns, message):
        data = message.encode() if hasattr(message, "encode") else json.dumps(message)
        written.append((topic, t_ns, data))

    pipeline = (CopyAtPublish if copy_at_publish else FlyPipeline)(
        config,
        inputs.rig,
        inputs.start,
        inputs.goal,
        write,
        on_row=rows.append,
        planner_thread=planner_thread,
    )
    timing = clock_config(config, inputs.rig)
    if copy_at_publish:
        timing = dataclasses.replace(timing, max_generation_cost_ns=None)
    clock = VirtualClock(pipeline, timing)
    for message in pair_stereo(reader.messages(SENSOR_TOPICS)):
        clock.feed(message.value)
    clock.finish(inputs.end_ns)
    pipeline.flush()
    pipeline.close()
    return written, [{k: ("nan" if v != v else v) for k, v in r.items()} for r in rows]


PAPER_RULE = replace_dotted(SMALL, {"obstacles.min_distinctness": 0.0})


@pytest.mark.parametrize("config", [PAPER_RULE, SMALL], ids=["paper-rule", "distinctness"])
def test_planner_on_its_own_thread_changes_no_output(config):
    inline, threaded = _pipeline_outputs(False, config), _pipeline_outputs(True, config)
    assert len(inline[0]) > 50 and len(inline[1]) == 21
    assert threaded == inline


def test_distinctness_is_written_charged_and_keeps_fewer_obstacle_flies(corridor_run, tmp_path):
    """The default rule measures distinctness: /flies carries it for the rule's candidates
    (NaN for the rest), its evaluations are charged to the run, and the planner sees a
    subset of what the paper's rule keeps (the same flies: in per-frame mode the engine's
    generations do not depend on the rule)."""
    plain_run = replay(CORRIDOR, tmp_path / "paper.mcap", PAPER_RULE)
    clouds = [m.value for m in open_log(corridor_run.output).messages([contract.FLIES])]
    plain = [m.value for m in open_log(plain_run.output).messages([contract.FLIES])]
    assert len(clouds) == len(plain) > 5
    kept = candidates = 0
    for cloud, same in zip(clouds, plain, strict=True):
        np.testing.assert_array_equal(cloud.xyz, same.xyz)
        assert cloud.distinct is not None and same.distinct is None
        base = PAPER_RULE.obstacles.mask(cloud.xyz, cloud.fitness, cloud.age)
        assert (np.isnan(cloud.distinct) == ~base).all()  # measured exactly for the candidates
        keep = SMALL.obstacles.mask(cloud.xyz, cloud.fitness, cloud.age, cloud.distinct)
        assert not (keep & ~base).any()
        kept, candidates = kept + keep.sum(), candidates + base.sum()
    assert 0 < kept < candidates
    shifts = len(SMALL.obstacles.distinct_shifts)
    assert corridor_run.generations == plain_run.generations
    assert corridor_run.evaluations - plain_run.evaluations >= candidates * (1 + shifts)


@pytest.mark.parametrize(
    "overrides",
    [{}, {"generations_per_frame": 0}, {"sync": True, "generations_per_frame": 3}],
    ids=["per-frame", "async", "sync"],
)
def test_copying_the_published_population_only_when_read_changes_no_output(overrides):
    config = replace_dotted(SMALL, overrides)
    lazy = _pipeline_outputs(False, config)
    assert lazy == _pipeline_outputs(False, config, copy_at_publish=True)
    assert len(lazy[0]) > 50


@pytest.mark.skipif(not sys.platform.startswith("linux"), reason="per-thread nice is Linux's")
def test_planner_worker_writes_every_output_on_its_own_nicer_thread():
    from flylog.geometry import Pose2D
    from flylog.io.readahead import HELPER_NICENESS
    from flylog.replay.pipeline import PLANNER_TICK, SNAPSHOT_TICK, FlyPipeline
    from flylog.sources.inputs import replay_inputs

    def nice() -> int:
        return os.getpriority(os.PRIO_PROCESS, threading.get_native_id())

    seen = []

    def write(topic, t_ns, message):
        seen.append((topic, threading.current_thread() is threading.main_thread(), nice()))

    rig = replay_inputs(open_log(CORRIDOR), goal=None).rig
    pipeline = FlyPipeline(
        SMALL,
        rig,
        Pose2D(0.0, 0.0, 0.0),
        (3.0, 0.0),
        write,
        on_row=lambda row: None,
        planner_thread=True,
    )
    try:
        pipeline.tick(PLANNER_TICK, 0)
        pipeline.tick(SNAPSHOT_TICK, 0)
        pipeline.flush()
    finally:
        pipeline.close()
    worker = min(19, nice() + HELPER_NICENESS)
    assert seen == [
        (contract.PLANNER_COMMAND, False, worker),
        (contract.PLANNER_POTENTIAL, False, worker),
        (contract.PLANNER_PATH, False, worker),
        (contract.PLANNER_MAP, False, worker),
    ]


# 700 sweeps settle the 200×200 field at planner.warm_start_omega (planner.omega needs 3100)
@pytest.mark.parametrize(("warm", "thread"), [(0, False), (700, False), (5000, True)])
def test_the_pipeline_starts_from_a_relaxed_obstacle_free_field(warm, thread):
    from flylog.geometry import Pose2D
    from flylog.replay.pipeline import FlyPipeline
    from flylog.sources.inputs import replay_inputs

    rig = replay_inputs(open_log(CORRIDOR), goal=None).rig
    config = replace_dotted(SMALL, {"planner.warm_start_sweeps": warm})
    pipeline = FlyPipeline(
        config, rig, Pose2D(0.0, 0.0, 0.0), (3.0, 0.0), lambda *a: None, planner_thread=thread
    )
    pipeline.flush()  # the warm start runs on the planner's worker when there is one
    pipeline.close()
    change = pipeline.planner.relax(1)  # what one more sweep still changes
    if warm:
        assert change <= config.planner.relax_tolerance
    else:
        assert change > 1e-3  # the log-distance guess is far from harmonic
