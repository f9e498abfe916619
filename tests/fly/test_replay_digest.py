"""Replays of a fixture log give the outputs recorded before the engine's refactoring into
measure definitions and back-ends (docs/architecture.md), bit for bit: the digests below were
recorded with that code (``python tests/fly/replay_digest.py LOG SEED [key=value ...]``).
Regenerating the fixture logs changes them; record them again then."""

from pathlib import Path

import pytest

from tests.fly.replay_digest import replay_digest

LOGS = Path(__file__).resolve().parents[2] / "fixtures" / "logs"

CASES = [
    # the default configuration (zssd, sub-pixel, heading, scouts while turning)
    ("turn.mcap", 0, {}, "96ecb19ca64244ef17a97b3a0d7f17e0804f649c9cf4912b804bfc532e4c069f"),
    (
        "turn.mcap",
        1,
        {"engine.similarity": "zncc", "engine.subpixel": False},
        "12380cb631e2169d5924104b5440ff216f13a8a7a114fdb7dc6ba4a0fbc963ea",
    ),
]


@pytest.mark.parametrize(("log", "seed", "overrides", "digest"), CASES)
def test_replay_outputs_are_the_recorded_ones(log, seed, overrides, digest):
    assert replay_digest(LOGS / log, seed, overrides) == digest
