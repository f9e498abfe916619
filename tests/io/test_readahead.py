"""Reading ahead in a thread: same messages, same order, errors and warnings where they
belong, and nothing left running when the consumer stops early."""

from __future__ import annotations

import os
import sys
import threading
import warnings

import pytest

from flylog.errors import LogError
from flylog.io import open_log
from flylog.io.readahead import (
    HELPER_NICENESS,
    batch_size,
    lower_thread_priority,
    read_ahead,
)
from flylog.io.scan import TruncatedLogWarning
from tests.io.conftest import write_sample


def _threads() -> set[str]:
    return {t.name for t in threading.enumerate() if t.name == "flylog-read-ahead"}


@pytest.mark.parametrize("depth", [1, 3, 100])
def test_items_come_in_order(depth):
    assert list(read_ahead(iter(range(50)), depth)) == list(range(50))
    assert not _threads()


def test_an_error_is_raised_where_it_happened():
    def source():
        yield from range(5)
        msg = "bad record"
        raise LogError(msg)

    got = []
    with pytest.raises(LogError, match="bad record"):
        for item in read_ahead(source(), 2):
            got.append(item)
    assert got == [0, 1, 2, 3, 4]
    assert not _threads()


def test_stopping_early_stops_the_thread_and_closes_the_source():
    closed = threading.Event()

    def source():
        try:
            yield from range(10_000)
        finally:
            closed.set()

    items = read_ahead(source(), 4)
    assert [next(items) for _ in range(3)] == [0, 1, 2]
    items.close()
    assert closed.is_set() and not _threads()


@pytest.mark.parametrize(("depth", "batch", "n"), [(64, None, 50), (64, 8, 3), (16, 5, 23)])
def test_batches_keep_the_order_and_raise_after_the_items_before_the_error(depth, batch, n):
    def source():
        yield from range(n)
        msg = "bad record"
        raise LogError(msg)

    assert list(read_ahead(iter(range(n)), depth, batch=batch)) == list(range(n))
    got = []
    with pytest.raises(LogError, match="bad record"):
        for item in read_ahead(source(), depth, batch=batch):
            got.append(item)
    assert got == list(range(n))
    assert not _threads()


def test_batch_size_keeps_eight_batches_within_the_depth():
    assert [batch_size(d) for d in (1, 8, 15, 16, 24, 64, 1000)] == [1, 1, 1, 2, 3, 8, 8]


def test_depth_must_be_positive():
    with pytest.raises(ValueError, match="at least 1"):
        list(read_ahead(iter([1]), 0))


def test_log_read_ahead_equals_plain_reading(tmp_path):
    sample = write_sample(tmp_path / "log.mcap", frames=6, chunk_size=4096)
    plain = list(open_log(sample.path).messages())
    ahead = list(open_log(sample.path).messages(read_ahead=5))
    assert [(m.topic, m.log_time_ns) for m in ahead] == [(m.topic, m.log_time_ns) for m in plain]
    assert len(plain) == sample.count


def test_truncated_log_warns_in_the_callers_thread(tmp_path):
    sample = write_sample(tmp_path / "log.mcap", frames=6, chunk_size=4096)
    data = sample.path.read_bytes()
    cut = tmp_path / "cut.mcap"
    cut.write_bytes(data[: len(data) // 2])
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        got = list(open_log(cut).messages(read_ahead=3))
    assert [w.category for w in caught] == [TruncatedLogWarning]
    assert f"recovered {len(got)} intact messages" in str(caught[0].message)
    assert caught[0].filename == __file__


def _nice() -> int:
    return os.getpriority(os.PRIO_PROCESS, threading.get_native_id())


linux_only = pytest.mark.skipif(
    not sys.platform.startswith("linux"), reason="per-thread nice values are Linux's"
)


@linux_only
def test_the_reading_thread_runs_nicer_than_the_consumer_which_keeps_its_own():
    mine = _nice()
    seen = []

    def source():
        seen.append(_nice())
        yield 1

    assert list(read_ahead(source(), 2)) == [1]
    assert seen == [min(19, mine + HELPER_NICENESS)]
    assert _nice() == mine


@linux_only
def test_lowering_a_thread_priority_touches_that_thread_only():
    mine = _nice()
    seen = []

    def lowered() -> None:
        seen.append(lower_thread_priority(3))
        seen.append(_nice())

    thread = threading.Thread(target=lowered)
    thread.start()
    thread.join()
    assert seen == [True, min(19, mine + 3)]
    assert _nice() == mine
    assert lower_thread_priority(0) is False
