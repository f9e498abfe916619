"""The digest of a replay's outputs: SHA-256 over the messages of the run's MCAP on the topics
the engine and the planner write (topic, log time, bytes, in file order) and over the values
of the step table's Parquet content in column order. Topics a run gained beside these (the
planner's obstacle map) and the table's column names (which carry units) are left out, so
that a digest recorded before them still tells whether the engine's output changed.
Run as a script with any installation of flylog to record a digest:

    python tests/fly/replay_digest.py LOG SEED [engine.key=value ...]
"""

from __future__ import annotations

import dataclasses
import enum
import hashlib
import sys
import tempfile
from pathlib import Path

import pyarrow.parquet as pq
from mcap.reader import make_reader

from flylog.config import replace_dotted
from flylog.replay.config import ReplayConfig
from flylog.replay.run import replay, table_path

# What the engine and the planner publish in a run.
TOPICS = ("/flies", "/flies/overlay", "/planner/potential", "/planner/path", "/planner/command")


def outputs_digest(run: Path) -> str:
    """SHA-256 of the messages of ``run`` on TOPICS and of its step table's values."""
    digest = hashlib.sha256()
    with run.open("rb") as stream:
        for _, channel, message in make_reader(stream).iter_messages(topics=TOPICS):
            digest.update(channel.topic.encode())
            digest.update(message.log_time.to_bytes(8, "little"))
            digest.update(message.data)
    table = pq.read_table(table_path(run))
    for name in table.column_names:
        digest.update(repr(table.column(name).to_pylist()).encode())
    return digest.hexdigest()


def replay_digest(log: Path, seed: int, overrides: dict[str, object]) -> str:
    """Replay ``log`` with the default configuration, ``seed`` and ``overrides`` (dotted
    names, e.g. ``engine.similarity``) and return :func:`outputs_digest`."""
    config = dataclasses.replace(ReplayConfig(), seed=seed)
    for dotted, value in overrides.items():
        current: object = config
        for name in dotted.split("."):
            current = getattr(current, name)
        if isinstance(current, enum.Enum):  # a file's string, as the TOML reader converts it
            value = type(current)(value)
        config = replace_dotted(config, {dotted: value})
    with tempfile.TemporaryDirectory() as tmp:
        run = Path(tmp) / "run.mcap"
        replay(log, run, config)
        return outputs_digest(run)


def _value(text: str) -> object:
    for kind in (int, float):
        try:
            return kind(text)
        except ValueError:
            pass
    return {"true": True, "false": False}.get(text, text)


if __name__ == "__main__":
    pairs = (item.split("=", 1) for item in sys.argv[3:])
    print(replay_digest(Path(sys.argv[1]), int(sys.argv[2]), {k: _value(v) for k, v in pairs}))
