"""The deterministic virtual clock that replays sensor data through an asynchronous pipeline.

The paper's point (Table 1) is that the fly engine never waits for a frame boundary: it runs
generation after generation, each on the newest data, and its population is readable at any
time. Replay models that on a virtual clock, so a run is deterministic whatever the machine:

- A sensor record becomes *available* at its log time (``--sync``: an image only once its whole
  capture cycle has ended, one frame period after its stamp).
- ``ASYNC``: generations run back to back. A generation starting at ``t`` first receives every
  record available at ``t``, then costs ``evaluations / evals_per_second`` of virtual time.
- ``PER_FRAME``: exactly N generations per stereo pair, starting when the pair is available (the
  paper's experiments); they still cost virtual time, and frames queue if the engine lags.
- ``SYNC`` (conventional pipeline): the engine processes complete frames only, N generations each,
  and its result is published only when that processing has ended.
- Periodic ticks (planner, snapshots) fire at their own rates and see the newest population
  *published* at or before their time, never one still being computed.
"""

from __future__ import annotations

import enum
import heapq
from collections.abc import Iterable, Iterator
from dataclasses import dataclass
from typing import Protocol

from flylog.sensors import StereoPair


class Mode(enum.Enum):
    ASYNC = "async"
    PER_FRAME = "per-frame"
    SYNC = "sync"


class Pipeline(Protocol):
    """What the clock drives (the engine + planner wiring implements it)."""

    def deliver(self, record: object) -> None:
        """A sensor record became available (stereo pair, sonar reading, odometry)."""

    def generation(self) -> int:
        """Run one generation on the newest data; return the fitness evaluations it made."""

    def publish(self, t_ns: int) -> None:
        """The population computed so far becomes what ticks see (at virtual time t_ns)."""

    def tick(self, name: str, t_ns: int) -> None:
        """A periodic tick (e.g. 'planner', 'snapshot') at virtual time t_ns."""


@dataclass(frozen=True)
class ClockConfig:
    mode: Mode
    evals_per_second: float
    generations_per_frame: int
    frame_period_ns: int
    tick_periods_ns: dict[str, int]


@dataclass
class ClockStats:
    generations: int = 0
    evaluations: int = 0
    frames: int = 0
    end_ns: int = 0


def _available_at(record: object, config: ClockConfig) -> int:
    stamp = record.stamp_ns  # type: ignore[attr-defined]
    if config.mode is Mode.SYNC and isinstance(record, StereoPair):
        return stamp + config.frame_period_ns
    return stamp


def run_clock(
    records: Iterable[object], pipeline: Pipeline, config: ClockConfig, *, end_ns: int
) -> Iterator[ClockStats]:
    """Drive ``pipeline`` over time-ordered ``records`` until ``end_ns``.

    Yields the running stats after every generation (the caller shows progress from
    ``stats.end_ns``). Every loop is bounded by the records and by ``end_ns``.
    """
    if config.evals_per_second <= 0:
        msg = "evals_per_second must be positive"
        raise ValueError(msg)
    stats = ClockStats()
    # Records become available in order of availability; SYNC delays images only, so keep a
    # small heap ordered by (available time, arrival index) rather than assume log order.
    pending: list[tuple[int, int, object]] = []
    source = iter(records)
    exhausted = False
    index = 0
    ticks = [(0, name) for name in sorted(config.tick_periods_ns)]
    first_ns: int | None = None
    now = 0

    def pull_until(t: int) -> None:
        nonlocal exhausted, index, first_ns
        while not exhausted and (not pending or pending[0][0] <= t):
            try:
                record = next(source)
            except StopIteration:
                exhausted = True
                return
            if first_ns is None:
                first_ns = record.stamp_ns  # type: ignore[attr-defined]
            heapq.heappush(pending, (_available_at(record, config), index, record))
            index += 1

    def fire_ticks_until(t: int) -> None:
        nonlocal ticks
        while ticks and ticks[0][0] <= t and ticks[0][0] <= end_ns:
            due, name = heapq.heappop(ticks)
            pipeline.tick(name, due)
            heapq.heappush(ticks, (due + config.tick_periods_ns[name], name))

    def deliver_until(t: int, *, stop_after_pair: bool) -> int:
        """Deliver the records available at t (up to and including the first stereo pair when
        ``stop_after_pair``); return how many stereo pairs were delivered."""
        pairs = 0
        pull_until(t)
        while pending and pending[0][0] <= t:
            _, _, record = heapq.heappop(pending)
            pipeline.deliver(record)
            if isinstance(record, StereoPair):
                pairs += 1
                if stop_after_pair:
                    break
            pull_until(t)
        return pairs

    pull_until(0)
    if first_ns is None:
        return
    now = first_ns
    ticks = [(first_ns, name) for name in sorted(config.tick_periods_ns)]
    heapq.heapify(ticks)
    have_pair = False
    # PER_FRAME gives every frame its N generations, so it takes frames one at a time even
    # when it lags; SYNC, like a conventional pipeline, processes the newest complete frame.
    one_frame_at_a_time = config.mode is Mode.PER_FRAME

    while now <= end_ns:
        new_pairs = deliver_until(now, stop_after_pair=one_frame_at_a_time)
        have_pair |= new_pairs > 0
        stats.frames += new_pairs
        if config.mode is Mode.ASYNC:
            runs = 1 if have_pair else 0
        else:
            runs = config.generations_per_frame if new_pairs > 0 else 0
        if runs == 0:
            # Nothing to work on: idle until the next record or tick.
            pull_until(now)
            candidates = [pending[0][0]] if pending else []
            if ticks:
                candidates.append(ticks[0][0])
            if not candidates or min(candidates) > end_ns:
                break
            nxt = max(min(candidates), now)
            fire_ticks_until(nxt)
            now = nxt if nxt > now else now + 1
            continue
        for _ in range(runs):
            evals = pipeline.generation()
            cost = max(1, round(evals * 1e9 / config.evals_per_second))
            # Ticks due while this generation runs see what was published before it.
            fire_ticks_until(now + cost - 1)
            now += cost
            stats.generations += 1
            stats.evaluations += evals
            if config.mode is not Mode.SYNC:
                pipeline.publish(now)
            stats.end_ns = now
            yield stats
        if config.mode is Mode.SYNC:
            pipeline.publish(now)
    fire_ticks_until(end_ns)
    stats.end_ns = end_ns
    yield stats
