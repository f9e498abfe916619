"""The virtual clock: availability, costs, per-frame counts, sync delays, tick visibility."""

import numpy as np
import pytest

from flylog.geometry import Pose2D
from flylog.replay.clock import ClockConfig, Mode, VirtualClock
from flylog.sensors import OdomReading, StereoPair

MS = 1_000_000
IMG = np.zeros((2, 2), np.uint8)


class Recorder:
    """A fake pipeline: each generation costs `evals`; records what it saw and when."""

    def __init__(self, evals: int = 1000, evals_per_second: float = 1e6) -> None:
        self.evals = evals
        self.evals_per_second = evals_per_second
        self.now_pair: int | None = None
        self.generations: list[int | None] = []  # pair stamp each generation worked on
        self.delivered: list[tuple[str, int]] = []
        self.published: list[tuple[int, int]] = []  # (t, generation count at publish)
        self.ticks: list[tuple[str, int, int]] = []  # (name, t, generations visible)
        self._visible = 0

    def deliver(self, record):
        self.delivered.append((type(record).__name__, record.stamp_ns))
        if isinstance(record, StereoPair):
            self.now_pair = record.stamp_ns

    def generation(self, tick_before_publish):
        self.generations.append(self.now_pair)
        return self.evals, round(self.evals * 1e9 / self.evals_per_second)

    def run_generations(self, count, tick_before_publish):
        return [self.generation(tick_before_publish) for _ in range(count)]

    def publish(self, t_ns):
        self._visible = len(self.generations)
        self.published.append((t_ns, self._visible))

    def tick(self, name, t_ns):
        self.ticks.append((name, t_ns, self._visible))


def frames(n: int, period_ms: int = 100) -> list[object]:
    out: list[object] = []
    for i in range(n):
        out.append(OdomReading(i * period_ms * MS, Pose2D(0.01 * i, 0, 0)))
        out.append(StereoPair(i * period_ms * MS, IMG, IMG))
    return out


def config(mode: Mode, gpf: int = 1, ticks=None) -> ClockConfig:
    return ClockConfig(mode, gpf, 100 * MS, ticks or {})


def run(records, pipeline, cfg, end_ns):
    clock = VirtualClock(pipeline, cfg)
    for record in records:
        clock.feed(record)
    return clock.finish(end_ns)


def test_async_runs_back_to_back_on_newest_pair():
    rec = Recorder(evals=10_000)  # 10 ms of virtual time at 1e6 evals/s
    stats = run(frames(5), rec, config(Mode.ASYNC), end_ns=500 * MS)
    # from t=0 to 500 ms at 10 ms per generation: 50 generations, +1 ending exactly at 500 ms
    assert stats.generations == 51
    assert stats.evaluations == 51 * 10_000
    # generation k starts at 10k ms and must work on the newest pair stamped <= its start
    for k, seen in enumerate(rec.generations):
        assert seen == min(k * 10 // 100, 4) * 100 * MS


def test_per_frame_runs_exactly_n_generations_per_frame_even_when_lagging():
    rec = Recorder(evals=60_000)  # 60 ms per generation, 3 per frame = 180 ms > 100 ms period
    stats = run(frames(4), rec, config(Mode.PER_FRAME, gpf=3), end_ns=10_000 * MS)
    assert stats.frames == 4
    assert rec.generations == [s * 100 * MS for s in range(4) for _ in range(3)]


def test_sync_sees_images_one_period_late_and_publishes_after_processing():
    rec = Recorder(evals=50_000)  # 50 ms per generation
    run(frames(3), rec, config(Mode.SYNC, gpf=2), end_ns=1000 * MS)
    # first frame (stamped 0) is complete at 100 ms; 2 generations → published at 200 ms
    assert rec.published[0] == (200 * MS, 2)
    assert rec.generations[:2] == [0, 0]
    # odometry is not delayed: the first odometry reading is delivered before the first image
    assert rec.delivered[0] == ("OdomReading", 0)


def test_ticks_see_only_published_population():
    rec = Recorder(evals=30_000)  # 30 ms generations
    run(frames(2), rec, config(Mode.SYNC, gpf=2, ticks={"planner": 100 * MS}), end_ns=400 * MS)
    # frame 0 available at 100 ms, its two generations end at 160 ms: the tick at 100 ms sees
    # nothing, the tick at 200 ms sees the two generations.
    visible = {t // MS: v for name, t, v in rec.ticks}
    assert visible[100] == 0
    assert visible[200] == 2
    assert sorted(visible) == [0, 100, 200, 300, 400]


def test_async_reacts_sooner_than_sync():
    def first_publish_with(mode, gpf):
        rec = Recorder(evals=5_000)
        run(frames(3), rec, config(mode, gpf=gpf), end_ns=300 * MS)
        return rec.published[0][0]

    assert first_publish_with(Mode.ASYNC, 1) < first_publish_with(Mode.SYNC, 1)


def test_deterministic_and_bounded():
    a, b = Recorder(), Recorder()
    run(frames(5), a, config(Mode.ASYNC, ticks={"s": 33 * MS}), end_ns=500 * MS)
    run(frames(5), b, config(Mode.ASYNC, ticks={"s": 33 * MS}), end_ns=500 * MS)
    assert a.ticks == b.ticks and a.generations == b.generations


def test_empty_log_runs_nothing():
    rec = Recorder()
    stats = run([], rec, config(Mode.ASYNC, ticks={"s": MS}), end_ns=10 * MS)
    assert stats.generations == 0 and rec.ticks == [] and rec.delivered == []


def test_incremental_advance_equals_feeding_everything():
    """The closed loop advances the clock in small steps between records: same result."""
    whole, steps = Recorder(evals=7_000), Recorder(evals=7_000)
    cfg = config(Mode.ASYNC, ticks={"planner": 100 * MS})
    run(frames(4), whole, cfg, end_ns=400 * MS)
    clock = VirtualClock(steps, cfg)
    t = 0
    for record in frames(4):
        # like the simulator asking for a command every 20 ms, never past the next record
        while t + 20 * MS < record.stamp_ns:
            t += 20 * MS
            clock.advance_to(t)
        clock.feed(record)
    clock.finish(400 * MS)
    assert steps.generations == whole.generations
    assert steps.ticks == whole.ticks


class Keeper(Recorder):
    """Records whether each generation was told a tick may come before the next publish,
    and whether a tick fired between a generation told none comes and the next publish."""

    def __init__(self, **kw) -> None:
        super().__init__(**kw)
        self.told: list[bool] = []
        self.dropped = False  # what was published is gone until the next publish
        self.bad_ticks: list[int] = []

    def generation(self, tick_before_publish):
        self.told.append(tick_before_publish)
        self.dropped |= not tick_before_publish
        return super().generation(tick_before_publish)

    def publish(self, t_ns):
        self.dropped = False
        super().publish(t_ns)

    def tick(self, name, t_ns):
        if self.dropped:
            self.bad_ticks.append(t_ns)
        super().tick(name, t_ns)


@pytest.mark.parametrize(("mode", "gpf"), [(Mode.ASYNC, 1), (Mode.PER_FRAME, 5), (Mode.SYNC, 5)])
def test_published_population_is_dropped_only_when_no_tick_can_read_it(mode, gpf):
    # 2 ms generations, ticks every 11 and 23 ms: some fall inside bursts of generations;
    # "edge" falls due on the last nanosecond of the generation that starts at 400 ms
    pipeline = Keeper(evals=2000, evals_per_second=1e6)
    ticks = {"a": 11 * MS, "b": 23 * MS, "edge": 402 * MS - 1}
    cfg = ClockConfig(mode, gpf, 100 * MS, ticks, 2 * MS)
    run(frames(6), pipeline, cfg, 600 * MS)
    assert pipeline.bad_ticks == []
    assert True in pipeline.told and False in pipeline.told  # the saving happens


def test_a_generation_costlier_than_the_bound_is_an_error():
    pipeline = Keeper(evals=3000, evals_per_second=1e6)  # 3 ms, the clock was told 2
    cfg = ClockConfig(Mode.PER_FRAME, 5, 100 * MS, {"a": 50 * MS}, 2 * MS)
    with pytest.raises(RuntimeError, match="more than the 2000000 ns"):
        run(frames(3), pipeline, cfg, 300 * MS)


def test_without_a_bound_every_generation_is_told_a_tick_may_come():
    pipeline = Keeper()
    run(frames(3), pipeline, config(Mode.PER_FRAME, 3, {"a": 30 * MS}), 300 * MS)
    assert pipeline.told and all(pipeline.told)


class Batcher(Recorder):
    """Records how many generations each call of run_generations asked for."""

    def __init__(self, **kw) -> None:
        super().__init__(**kw)
        self.batches: list[int] = []

    def run_generations(self, count, tick_before_publish):
        self.batches.append(count)
        return super().run_generations(count, tick_before_publish)


@pytest.mark.parametrize("mode", [Mode.PER_FRAME, Mode.SYNC])
def test_generations_no_tick_can_come_between_run_in_one_call(mode):
    # 2 ms generations, 10 a frame; ticks every 11 and 23 ms and one on the last nanosecond
    # of a generation: the runs between them go in one call, and every tick sees the same
    ticks = {"a": 11 * MS, "b": 23 * MS, "edge": 402 * MS - 1}
    seen = []
    for bounds in ((None, None), (2 * MS, 2 * MS), (3 * MS, 2 * MS)):
        pipeline = Batcher(evals=2000, evals_per_second=1e6)
        cfg = ClockConfig(mode, 10, 100 * MS, ticks, *bounds)
        stats = run(frames(6), pipeline, cfg, 600 * MS)
        seen.append((stats, pipeline.generations, pipeline.ticks, pipeline.delivered))
        assert (max(pipeline.batches, default=0) > 1) == (bounds[0] is not None)
    assert seen[1] == seen[0] and seen[2] == seen[0]


def test_a_later_generation_costlier_than_its_bound_is_an_error():
    pipeline = Batcher(evals=3000, evals_per_second=1e6)  # 3 ms: the first may, not the next
    cfg = ClockConfig(Mode.PER_FRAME, 5, 100 * MS, {"a": 50 * MS}, 3 * MS, 2 * MS)
    with pytest.raises(RuntimeError, match="more than the 2000000 ns"):
        run(frames(3), pipeline, cfg, 300 * MS)
