"""The reader on a few hundred seeded mutants of two small logs (one chunk; thirteen lz4
chunks), in a worker process with a time limit: every mutant reads identical, is recovered
with a warning naming what was lost, or fails with a LogError (tests/io/fuzz.py)."""

from __future__ import annotations

import itertools
from pathlib import Path

import numpy as np
import pytest

from .conftest import write_sample
from .fuzz import ACCEPTED, FAILURES, run
from .mutate import MUTATIONS, mutate, record_spans

MUTANTS = 125  # per log, 250 in all: ~5 s of CPU


@pytest.fixture(scope="module")
def logs(tmp_path_factory: pytest.TempPathFactory) -> list[Path]:
    d = tmp_path_factory.mktemp("fuzz")
    one = write_sample(d / "one-chunk.mcap").path
    many = write_sample(d / "lz4-chunks.mcap", frames=12, chunk_size=8192, compression="lz4")
    return [one, many.path]


def test_seeded_mutants_read_identical_recovered_or_a_log_error(logs):
    counts, failures, kept = run(logs, MUTANTS, workers=1)
    assert failures == []
    for log in logs:
        found = counts[str(log)]
        assert sum(found.values()) == MUTANTS
        assert set(found) <= set(ACCEPTED) and not set(found) & set(FAILURES)
        assert found["recovered"] > 0  # the harness does reach damage it must report
        assert all(0 <= k <= 1 for k in kept[str(log)])


def test_mutations_are_seeded_and_of_every_kind(logs):
    data = logs[1].read_bytes()
    assert [mutate(data, np.random.default_rng(s)) for s in range(5)] == [
        mutate(data, np.random.default_rng(s)) for s in range(5)
    ]
    kinds = {mutate(data, np.random.default_rng(s))[1].split()[0] for s in range(200)}
    assert kinds == {k.split("_")[0] for k in MUTATIONS}


def test_record_spans_tile_the_file_between_its_magics(logs):
    data = logs[1].read_bytes()
    spans = record_spans(data)
    assert spans[0][0] == 8 and spans[-1][1] == len(data) - 8
    assert all(a[1] == b[0] for a, b in itertools.pairwise(spans))
