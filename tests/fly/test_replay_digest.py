"""Replays of a fixture log give the recorded outputs, bit for bit
(``python tests/fly/replay_digest.py LOG SEED [key=value ...]`` records them). The first two
cases check the engine's refactoring into measure definitions and back-ends
(docs/architecture.md): their outputs are those of the code before it, but for one
placement: a snapshot's flies and odom → base_link are at the robot's pose at the snapshot's
stamp (the newest odometry carried on to it), where that code took the newest odometry
reading itself. Regenerating the fixture logs changes them; record them again then. The
planner runs as it did then, with unknown cells free (``planner.frontier_field`` off), and on
the images as they come (``engine.photometric = "none"``, the default then). The last case
is the default configuration's, with the photometric matching (``flylog.fly.photometric``)."""

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
        "cb8d3c00c489a38037e086bb931465ece4259e5bf19a303bc4367388587dcfa6",
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
        "c3c0882a6f5f465ffe37ea7e32e4a3e1fcc461c604477b1d962f5bc7d241616a",
    ),
    # the default configuration
    (
        "turn.mcap",
        0,
        {"planner.frontier_field": False},
        "4006871dc0b9a3d7c48877ca2e3766f4e345646cced1eb99a412a7398e7389d0",
    ),
]


@pytest.mark.parametrize(("log", "seed", "overrides", "digest"), CASES)
def test_replay_outputs_are_the_recorded_ones(log, seed, overrides, digest):
    assert replay_digest(LOGS / log, seed, overrides) == digest
