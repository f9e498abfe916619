"""Replays of a fixture log give the outputs recorded before the engine's refactoring into
measure definitions and back-ends (docs/architecture.md), bit for bit: the digests below were
recorded with that code (``python tests/fly/replay_digest.py LOG SEED [key=value ...]``).
Regenerating the fixture logs changes them; record them again then. The planner runs as it
did then, with unknown cells free (``planner.frontier_field`` off), and on the images as they
come (``engine.photometric = "none"``, the default then). The last case is the default
configuration's, recorded with the photometric matching (``flylog.fly.photometric``)."""

from pathlib import Path

import pytest

from tests.fly.replay_digest import replay_digest

LOGS = Path(__file__).resolve().parents[2] / "fixtures" / "logs"

CASES = [
    # zssd, sub-pixel, heading, scouts while turning
    (
        "turn.mcap",
        0,
        {"planner.frontier_field": False, "engine.photometric": "none"},
        "398113da2a5c760f7cd86e7a8d18dade0973756be93a4b4dddde46990167e84b",
    ),
    (
        "turn.mcap",
        1,
        {
            "engine.similarity": "zncc",
            "engine.subpixel": False,
            "planner.frontier_field": False,
            "engine.photometric": "none",
        },
        "60998ecdf6c659dc3ea27cdf046f5cf4c217157a316f80e7d9403d07bbbb330c",
    ),
    # the default configuration
    (
        "turn.mcap",
        0,
        {"planner.frontier_field": False},
        "d1f4886736b67a0ee35052400431cbb4073ae37bd9c6ec12d36b6b2914c1d7a5",
    ),
]


@pytest.mark.parametrize(("log", "seed", "overrides", "digest"), CASES)
def test_replay_outputs_are_the_recorded_ones(log, seed, overrides, digest):
    assert replay_digest(LOGS / log, seed, overrides) == digest
