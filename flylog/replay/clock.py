"""The deterministic virtual clock that replays sensor data through an asynchronous pipeline.

The paper's point (Table 1) is that the fly engine never waits for a frame boundary: it runs
generation after generation, each on the newest data, and its population is readable at any
time. Replay models that on a virtual clock, so a run is deterministic whatever the machine:

- A sensor record becomes *available* at its log time (``--sync``: an image only once its whole
  capture cycle has ended, one frame period after its stamp).
- ``ASYNC``: generations run back to back. A generation starting at ``t`` first receives every
  record available at ``t``, then costs the virtual time the pipeline reports for it (for
  the fly engine: its fitness evaluations / ``evals_per_second``).
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
from dataclasses import dataclass
from typing import Protocol

from flylog.sensors import StereoPair


class Mode(enum.Enum):
    ASYNC = "async"
    PER_FRAME = "per-frame"
    SYNC = "sync"


class Pipeline(Protocol):
    """What the clock drives, and when: the one statement of the calls a pipeline receives
    (:class:`flylog.replay.pipeline.FlyPipeline` implements it for the engine and the
    planner).

    The clock calls, in the order of virtual time:

    1. :meth:`deliver` for each record once it is available, before any generation that
       starts at or after that time;
    2. :meth:`generation`, or :meth:`run_generations` for several that nothing can come
       between: back to back (``ASYNC``) or N per stereo pair (``PER_FRAME``, ``SYNC``);
    3. :meth:`publish` after each generation (after the last of a :meth:`run_generations`
       call), or, ``SYNC``, after a frame's N generations;
    4. :meth:`tick` at each due time of ``ClockConfig.tick_periods_ns``. A tick due while
       a generation runs fires after that generation's call: it reads what was published
       before, never a population still being computed.

    ``tick_before_publish`` says whether a tick may fire after the call's generations start
    and before the next :meth:`publish`. False (the clock knows ``max_generation_cost_ns``
    and no tick falls due in time) lets the pipeline drop what was published last instead
    of copying it: no tick can read it.
    """

    def deliver(self, record: object) -> None:
        """A sensor record became available (stereo pair, sonar reading, odometry)."""

    def generation(self, tick_before_publish: bool, /) -> tuple[int, int]:
        """Run one generation on the newest data; return the fitness evaluations it made
        and the virtual time it costs (ns, at least 1)."""

    def run_generations(self, count: int, tick_before_publish: bool, /) -> list[tuple[int, int]]:
        """``count`` generations as ``count`` calls of :meth:`generation` make them, each
        one's (evaluations, cost), asked for only when no record and no tick can come
        between them, so nothing can see the populations between."""

    def publish(self, t_ns: int) -> None:
        """The population computed so far becomes what ticks see (at virtual time t_ns)."""

    def tick(self, name: str, t_ns: int) -> None:
        """A periodic tick (a name of ``ClockConfig.tick_periods_ns``) at virtual time
        t_ns."""


@dataclass(frozen=True)
class ClockConfig:
    mode: Mode
    generations_per_frame: int
    frame_period_ns: int
    tick_periods_ns: dict[str, int]
    # The most virtual time one generation can cost (None: unknown). Given, the pipeline is
    # told when no tick can fire before the next publish (most generations: the pipeline
    # then needs no copy of the published population).
    max_generation_cost_ns: int | None = None
    # The most a generation can cost when it follows another with no record delivered and
    # no tick fired between them (None: max_generation_cost_ns). The generations that no
    # tick can fire between run in one call of the pipeline (run_generations).
    max_later_generation_cost_ns: int | None = None


@dataclass
class ClockStats:
    generations: int = 0
    evaluations: int = 0
    frames: int = 0
    now_ns: int = 0


class VirtualClock:
    """Push-based: ``feed`` records in log order, ``advance_to`` a time, ``finish`` at the end.

    Feeding a record stamped ``s`` first advances to ``s - 1``: every record that can be
    available before ``s`` has then been fed (availability is never before the stamp), so a
    generation never starts without data it should have seen. The simulator's closed loop
    uses the same clock, feeding records as it produces them.
    """

    def __init__(self, pipeline: Pipeline, config: ClockConfig) -> None:
        self.pipeline = pipeline
        self.config = config
        self.stats = ClockStats()
        self._pending: list[tuple[int, int, object]] = []
        self._index = 0
        self._ticks: list[tuple[int, str]] = []
        self._started = False
        self._have_pair = False

    def feed(self, record: object) -> None:
        stamp = record.stamp_ns  # type: ignore[attr-defined]
        if not self._started:
            self._started = True
            self.stats.now_ns = stamp
            self._ticks = [(stamp, name) for name in sorted(self.config.tick_periods_ns)]
        else:
            self.advance_to(stamp - 1)
        heapq.heappush(self._pending, (_available_at(record, self.config), self._index, record))
        self._index += 1

    def advance_to(self, t_ns: int) -> None:
        """Run generations starting at or before ``t_ns``, and fire the ticks due meanwhile."""
        if not self._started:
            return
        cfg, stats = self.config, self.stats
        # PER_FRAME gives every frame its N generations, so it takes frames one at a time even
        # when it lags; SYNC, like a conventional pipeline, processes the newest complete frame.
        one_frame_at_a_time = cfg.mode is Mode.PER_FRAME
        while stats.now_ns <= t_ns:
            new_pairs = self._deliver(stats.now_ns, stop_after_pair=one_frame_at_a_time)
            self._have_pair |= new_pairs > 0
            stats.frames += new_pairs
            if cfg.mode is Mode.ASYNC:
                runs = 1 if self._have_pair else 0
            else:
                runs = cfg.generations_per_frame if new_pairs > 0 else 0
            if runs == 0:
                # Idle until the next record or tick, or until what has been fed runs out.
                candidates = [t_ns + 1]
                if self._pending:
                    candidates.append(self._pending[0][0])
                if self._ticks:
                    candidates.append(self._ticks[0][0])
                nxt = max(min(candidates), stats.now_ns + 1)
                self._fire_ticks_until(nxt - 1)
                stats.now_ns = nxt
                continue
            i = 0
            while i < runs:
                # No record comes between a frame's generations: those that no tick can
                # fire between run in one call (they publish after each, as the others do,
                # but only the last can be seen).
                batch = self._tickless_generations(runs - i)
                if batch > 1:
                    # SYNC: a tick after these but before the frame's end sees the population
                    # published before them
                    tick_before = cfg.mode is Mode.SYNC and self._tick_before(runs - i)
                    bound = cfg.max_generation_cost_ns
                    for evals, cost in self.pipeline.run_generations(batch, tick_before):
                        self._charge(evals, cost, tick_before_publish=tick_before, bound=bound)
                        bound = self._later_bound
                    i += batch
                    if cfg.mode is not Mode.SYNC:
                        self.pipeline.publish(stats.now_ns)
                    continue
                # SYNC publishes once the frame's generations are done, the others after each
                tick_before = self._tick_before(runs - i if cfg.mode is Mode.SYNC else 1)
                evals, cost = self.pipeline.generation(tick_before)
                self._charge(
                    evals, cost, tick_before_publish=tick_before, bound=cfg.max_generation_cost_ns
                )
                i += 1
                if cfg.mode is not Mode.SYNC:
                    self.pipeline.publish(stats.now_ns)
            if cfg.mode is Mode.SYNC:
                self.pipeline.publish(stats.now_ns)

    def _charge(
        self, evals: int, cost: int, *, tick_before_publish: bool, bound: int | None
    ) -> None:
        """Account for a generation that made ``evals`` evaluations and costs ``cost`` (at
        most ``bound`` when the pipeline was told that no tick comes before the next
        publish), and fire the ticks due while it ran (they see what was published before
        it)."""
        stats = self.stats
        cost = max(1, cost)
        if not tick_before_publish and cost > (bound or 0):
            msg = (
                f"a generation cost {cost} ns of virtual time, more than the "
                f"{bound} ns the clock was told it can cost"
            )
            raise RuntimeError(msg)
        self._fire_ticks_until(stats.now_ns + cost - 1)
        stats.now_ns += cost
        stats.generations += 1
        stats.evaluations += evals

    def finish(self, end_ns: int) -> ClockStats:
        """Run until ``end_ns`` (the log's end) and fire the ticks due until then."""
        self.advance_to(end_ns)
        self._fire_ticks_until(end_ns)
        return self.stats

    @property
    def _later_bound(self) -> int | None:
        cfg = self.config
        return cfg.max_later_generation_cost_ns or cfg.max_generation_cost_ns

    def _tickless_generations(self, most: int) -> int:
        """How many of the next ``most`` generations (with nothing delivered between them)
        can run with no tick firing before the last has ended (0 when the generations'
        cost is not bounded)."""
        bound, later = self.config.max_generation_cost_ns, self._later_bound
        if not bound or not later:
            return 0
        if not self._ticks:
            return most
        gap = self._ticks[0][0] - self.stats.now_ns
        return 0 if gap < bound else min(most, 1 + (gap - bound) // later)

    def _tick_before(self, generations: int) -> bool:
        """Whether a tick may fire within the next ``generations`` generations."""
        most = self.config.max_generation_cost_ns
        if most is None:
            return True
        return bool(self._ticks) and self._ticks[0][0] < self.stats.now_ns + generations * most

    def _deliver(self, t: int, *, stop_after_pair: bool) -> int:
        pairs = 0
        while self._pending and self._pending[0][0] <= t:
            _, _, record = heapq.heappop(self._pending)
            self.pipeline.deliver(record)
            if isinstance(record, StereoPair):
                pairs += 1
                if stop_after_pair:
                    break
        return pairs

    def _fire_ticks_until(self, t: int) -> None:
        while self._ticks and self._ticks[0][0] <= t:
            due, name = heapq.heappop(self._ticks)
            self.pipeline.tick(name, due)
            heapq.heappush(self._ticks, (due + self.config.tick_periods_ns[name], name))


def _available_at(record: object, config: ClockConfig) -> int:
    stamp = record.stamp_ns  # type: ignore[attr-defined]
    if config.mode is Mode.SYNC and isinstance(record, StereoPair):
        return stamp + config.frame_period_ns
    return stamp
