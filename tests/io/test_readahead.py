"""Reading ahead in a thread: same messages, same order, errors and warnings where they
belong, and nothing left running when the consumer stops early."""

from __future__ import annotations

import threading
import warnings

import pytest

from flylog.errors import LogError
from flylog.io import open_log
from flylog.io.readahead import read_ahead
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
