"""The reader on a few hundred seeded mutants of two small logs (one chunk; thirteen lz4
chunks), in a worker process with a time limit: every mutant reads identical, is recovered
with a warning naming what was lost, or fails with a LogError (tests/io/fuzz.py)."""

from __future__ import annotations

import itertools
from pathlib import Path

import numpy as np
import pytest

from .conftest import write_sample
from .fuzz import ACCEPTED, FAILURES, Target, run
from .mutate import MUTATIONS, delete_chunks, mutate, record_spans

MUTANTS = 125  # per log, 250 in all: ~5 s of CPU
CHUNK_DELETIONS = 20


@pytest.fixture(scope="module")
def logs(tmp_path_factory: pytest.TempPathFactory) -> list[Path]:
    d = tmp_path_factory.mktemp("fuzz")
    one = write_sample(d / "one-chunk.mcap").path
    many = write_sample(d / "lz4-chunks.mcap", frames=12, chunk_size=8192, compression="lz4")
    return [one, many.path]


def test_seeded_mutants_read_identical_recovered_or_a_log_error(logs):
    targets = [Target(log, MUTANTS) for log in logs]
    targets.append(Target(logs[1], CHUNK_DELETIONS, mutation="chunks"))
    counts, failures, kept = run(targets, workers=1)
    assert failures == []
    for target in targets:
        found = counts[target.label]
        classes = {c: n for c, n in found.items() if c in (*ACCEPTED, *FAILURES)}
        assert sum(classes.values()) == target.mutants
        assert not set(classes) & set(FAILURES)
        assert found["recovered"] > 0  # the harness does reach damage it must report
        assert found["exact"] + found["bound"] == found["recovered"]
        assert all(0 <= k <= 1 for k in kept[target.label])
    # a whole chunk deleted is always a loss counted exactly
    assert counts[targets[-1].label]["exact"] == CHUNK_DELETIONS


def test_chunk_deletions_are_seeded_and_delete_whole_chunks(logs):
    data = logs[1].read_bytes()
    mutant, how = delete_chunks(data, np.random.default_rng(3))
    assert (mutant, how) == delete_chunks(data, np.random.default_rng(3))
    assert how.startswith("delete chunks") and len(mutant) < len(data)
    assert record_spans(mutant)[-1][1] == len(mutant) - 8  # records still tile the file


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
