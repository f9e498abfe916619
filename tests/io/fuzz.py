"""Fuzzing the reader: seeded mutants of a log (:mod:`tests.io.mutate`), each read whole by
``flylog.io.open_log`` (a ROS 2 bag's MCAP file by ``flylog.ros2.bag.open_bag``) in a worker
process with a time limit, and classified.

Accepted outcomes:

- ``identical``: read like the original, no warning;
- ``warned``: read like the original, with a DamagedLogWarning naming what is damaged (a
  summary, say, when the data section holds every message);
- ``recovered``: a DamagedLogWarning (or TruncatedLogWarning) names what was skipped and
  counts the messages lost, and what was read is the original's messages, attachments and
  metadata records in order with some left out (nothing changed, nothing invented). The
  warnings' count (:func:`flylog.io.scan.messages_lost`) must be the number of messages
  missing (``exact``), or for a cut log, whose counts lay in its lost summary, at most
  that number and said to be a lower bound (``bound``);
- ``error``: a flylog LogError.

Failures: ``exception`` (any other exception), ``silent`` (a read that differs from the
original with no warning), ``invented`` (a warned read holding a message, attachment or
metadata record the original lacks, or a value it changed), ``miscounted`` (the warnings'
count of the messages lost is wrong), ``hang`` (no answer within the limit). "Read whole" is
the topics, time range, attachments, metadata records and every decoded message.

Each log given is first copied as flylog writes logs (its records byte for byte, its
metadata records with their checksums); ``--lz4-copy`` adds a copy in many lz4 chunks,
``--chunk-deletions`` mutants of that copy with whole chunks deleted, ``--bag-mutants``
mutants of the log's ``flylog export --ros2`` bag.

``python -m tests.io.fuzz LOG... --mutants N`` prints the counts per log and class and
exits 1 on any failure (``make fuzz``).
"""

from __future__ import annotations

import argparse
import dataclasses
import hashlib
import json
import os
import select
import subprocess
import sys
import tempfile
import time
import warnings
from collections import Counter
from collections.abc import Iterable
from pathlib import Path
from typing import Any

import numpy as np

from .mutate import mutate

ACCEPTED = ("identical", "warned", "recovered", "error")
FAILURES = ("exception", "silent", "invented", "miscounted", "hang")
TIME_LIMIT_S = 5.0
LOG_CHUNK_SIZE = 4 << 20  # LogConfig's: a small log is one chunk


def _digest(value: Any, h: Any) -> None:
    if isinstance(value, np.ndarray):
        h.update(f"{value.dtype}{value.shape}".encode())
        h.update(np.ascontiguousarray(value).tobytes())
    elif dataclasses.is_dataclass(value) and not isinstance(value, type):
        for f in dataclasses.fields(value):
            _digest(getattr(value, f.name), h)
    elif isinstance(value, tuple | list):
        h.update(f"[{len(value)}".encode())
        for v in value:
            _digest(v, h)
    elif isinstance(value, dict):
        for k in sorted(value, key=str):
            h.update(str(k).encode())
            _digest(value[k], h)
    else:
        h.update(repr(value).encode())


def message_key(m: Any) -> tuple[str, int, str, str]:
    """A message as compared: a flylog log's LogMessage or a bag's BagMessage."""
    h = hashlib.blake2b(digest_size=16)
    _digest(m.value, h)
    schema = m.schema if hasattr(m, "schema") else m.msgtype
    return (m.topic, m.log_time_ns, schema, h.hexdigest())


@dataclasses.dataclass(frozen=True)
class Reading:
    """What reading a log whole gave."""

    topics: tuple[tuple[str, str, int], ...]
    times: tuple[int, int]
    attachments: tuple[tuple[str, str, int, str], ...]
    metadata: tuple[tuple[str, tuple[tuple[str, str], ...]], ...]
    messages: tuple[tuple[str, int, str, str], ...]


@dataclasses.dataclass(frozen=True)
class Damage:
    """The DamagedLogWarnings of a reading: their lines, and the messages they say were
    lost (``exact``: False when some were lost uncounted, a cut log's, then a lower bound)."""

    lines: tuple[str, ...]
    lost: int
    exact: bool


def read_whole(path: Path, kind: str = "log") -> tuple[Reading, Damage]:
    """The log (``kind`` "bag": a ROS 2 bag's MCAP file, its messages decoded as CDR) read
    whole, and the damage warnings reading it gave."""
    from flylog.io import DamagedLogWarning, open_log
    from flylog.io.scan import messages_lost

    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        log = open_log(path)
        source: Any = log
        if kind == "bag":
            from flylog.ros2.bag import open_bag

            source = open_bag(path)
        topics = tuple((t, i.schema, i.count) for t, i in source.topics().items())
        times = (source.start_ns, source.end_ns)
        attachments = tuple(
            (a.name, a.media_type, a.log_time_ns, hashlib.sha256(a.data).hexdigest())
            for a in log.attachments()
        )
        metadata = tuple((k, tuple(sorted(v.items()))) for k, v in sorted(log.metadata().items()))
        messages = tuple(message_key(m) for m in source.messages())
    found = [w.message for w in caught if issubclass(w.category, DamagedLogWarning)]
    lost, exact = messages_lost(found)
    damage = Damage(tuple(str(w) for w in found), lost, exact)
    return Reading(topics, times, attachments, metadata, messages), damage


def _is_subsequence(part: Iterable[Any], whole: Iterable[Any]) -> bool:
    rest = iter(whole)
    return all(any(p == w for w in rest) for p in part)


def classify(original: Reading, path: Path, kind: str = "log") -> tuple[str, str]:
    """The class of reading ``path`` (a mutant of the log ``original`` was read from) and a
    detail: the warning, the error or the exception. A recovered read's detail starts with
    the share of the messages kept and whether the warnings counted the loss exactly."""
    from flylog.errors import LogError

    try:
        got, damage = read_whole(path, kind)
    except LogError as exc:
        return "error", str(exc)
    except Exception as exc:
        return "exception", f"{type(exc).__name__}: {exc}"
    if not damage.lines:
        return ("identical", "") if got == original else ("silent", _difference(original, got))
    if got == original:
        return "warned", damage.lines[0]  # read whole, with a warning about what is damaged
    if not (
        _is_subsequence(got.messages, original.messages)
        and _is_subsequence(got.attachments, original.attachments)
        and _is_subsequence(got.metadata, original.metadata)
    ):
        return "invented", f"{_difference(original, got)}; warned: {damage.lines[0]}"
    missing = len(original.messages) - len(got.messages)
    if (damage.exact and damage.lost != missing) or (not damage.exact and damage.lost > missing):
        said = f"{damage.lost}{'' if damage.exact else ' or more'}"
        return "miscounted", f"{missing} messages lost, the warnings say {said}: {damage.lines}"
    kept = len(got.messages) / max(1, len(original.messages))
    counted = "exact" if damage.exact else "bound"
    return "recovered", f"kept {kept:.4f} {counted}; {damage.lines[0]}"


def _difference(a: Reading, b: Reading) -> str:
    for name in ("topics", "times", "attachments", "metadata"):
        if getattr(a, name) != getattr(b, name):
            return f"{name}: {getattr(a, name)} became {getattr(b, name)}"
    return f"messages: {len(a.messages)} became {len(b.messages)}"


# ---- the worker: reads jobs (log path, seed) as JSON lines on stdin -----------------------


def worker(scratch: Path) -> None:
    from .mutate import delete_chunks

    originals: dict[tuple[str, str], tuple[bytes, Reading]] = {}
    target = scratch / f"mutant-{os.getpid()}.mcap"
    for line in sys.stdin:
        job = json.loads(line)
        log, kind = job["log"], job.get("kind", "log")
        if (log, kind) not in originals:
            originals[log, kind] = (Path(log).read_bytes(), read_whole(Path(log), kind)[0])
        data, original = originals[log, kind]
        damage = delete_chunks if job.get("mutation") == "chunks" else mutate
        mutant, how = damage(data, np.random.default_rng(job["seed"]))
        target.write_bytes(mutant)
        found, detail = classify(original, target, kind)
        print(json.dumps({"seed": job["seed"], "class": found, "how": how, "detail": detail}))
        sys.stdout.flush()


class _Worker:
    def __init__(self, scratch: Path) -> None:
        root = Path(__file__).resolve().parents[2]
        self.process = subprocess.Popen(
            [sys.executable, "-m", "tests.io.fuzz", "--worker", str(scratch)],
            cwd=root,
            stdin=subprocess.PIPE,
            stdout=subprocess.PIPE,
            text=True,
        )
        self.job: dict[str, Any] | None = None
        self.started = 0.0

    def give(self, job: dict[str, Any]) -> None:
        assert self.process.stdin is not None
        self.job, self.started = job, time.monotonic()
        self.process.stdin.write(json.dumps(job) + "\n")
        self.process.stdin.flush()

    def stop(self) -> None:
        self.process.kill()
        self.process.wait()


@dataclasses.dataclass(frozen=True)
class Target:
    """A file to fuzz: a flylog log or (``kind`` "bag") a ROS 2 bag's MCAP file, damaged by
    :func:`~tests.io.mutate.mutate` (``mutation`` "bytes") or by deleting whole chunks
    (:func:`~tests.io.mutate.delete_chunks`, "chunks")."""

    log: Path
    mutants: int
    kind: str = "log"
    mutation: str = "bytes"

    @property
    def label(self) -> str:
        return f"{self.log}" + (" (chunks deleted)" if self.mutation == "chunks" else "")


def _job(target: Target) -> dict[str, Any]:
    return {
        "log": str(target.log),
        "kind": target.kind,
        "mutation": target.mutation,
        "label": target.label,
    }


def run(
    targets: list[Target], *, workers: int = 2, first_seed: int = 0
) -> tuple[dict[str, Counter[str]], list[dict[str, Any]], dict[str, list[float]]]:
    """Classify the seeded mutants of each target in ``workers`` processes; the counts per
    target and class (and of the recovered reads whose loss was counted exactly,
    ``exact``, or as a lower bound of a cut log, ``bound``), the failing mutants (log,
    seed, class, damage, detail), and the share of the messages each recovered read kept."""
    jobs = [{**_job(t), "seed": first_seed + k} for t in targets for k in range(t.mutants)][::-1]
    counts: dict[str, Counter[str]] = {t.label: Counter() for t in targets}
    kept: dict[str, list[float]] = {t.label: [] for t in targets}
    failures: list[dict[str, Any]] = []
    with tempfile.TemporaryDirectory(prefix="flylog-fuzz-") as scratch:
        pool = [_Worker(Path(scratch)) for _ in range(max(1, workers))]
        busy: dict[int, _Worker] = {}
        try:
            while jobs or busy:
                for w in pool:
                    if w.job is None and jobs:
                        w.give(jobs.pop())
                busy = {w.process.stdout.fileno(): w for w in pool if w.job is not None}  # type: ignore[union-attr]
                if not busy:
                    break
                soonest = min(w.started for w in busy.values()) + TIME_LIMIT_S
                ready, _, _ = select.select(
                    list(busy), [], [], max(0.0, soonest - time.monotonic())
                )
                for fd in ready:
                    w = busy[fd]
                    assert w.process.stdout is not None and w.job is not None
                    line = w.process.stdout.readline()
                    result = (
                        json.loads(line)
                        if line
                        else {"class": "exception", "how": "", "detail": "the worker died"}
                    )
                    counts[w.job["label"]][result["class"]] += 1
                    if result["class"] == "recovered":
                        kept[w.job["label"]].append(float(result["detail"].split()[1]))
                        counts[w.job["label"]][result["detail"].split()[2].rstrip(";")] += 1
                    if result["class"] in FAILURES:
                        failures.append({**w.job, **result})
                    w.job = None
                now = time.monotonic()
                for i, w in enumerate(pool):
                    if w.job is not None and now - w.started > TIME_LIMIT_S:
                        counts[w.job["label"]]["hang"] += 1
                        failures.append({**w.job, "class": "hang", "how": "", "detail": ""})
                        w.stop()
                        pool[i] = _Worker(Path(scratch))
                    elif w.job is None and w.process.poll() is not None:
                        pool[i] = _Worker(Path(scratch))
        finally:
            for w in pool:
                w.stop()
    return counts, failures, kept


def rechunked(source: Path, target: Path, *, chunk_size: int, compression: str = "lz4") -> Path:
    """``target``: ``source``'s records, byte for byte, in chunks of ``chunk_size`` bytes;
    its metadata records with their checksums and its header marked, as flylog's writer
    writes them (docs/log-integrity.md)."""
    from mcap.reader import make_reader
    from mcap.writer import CompressionType, Writer

    from flylog.io import contract

    with source.open("rb") as src, target.open("wb") as fh:
        reader = make_reader(src)
        writer = Writer(
            fh,
            chunk_size=chunk_size,
            compression=CompressionType[compression.upper()],
            use_summary_offsets=False,
        )
        writer.start(profile="", library=f"fuzz{contract.METADATA_CRC_MARK}")
        for m in reader.iter_metadata():
            values = {k: v for k, v in m.metadata.items() if k != contract.METADATA_CRC_KEY}
            values[contract.METADATA_CRC_KEY] = contract.metadata_crc(m.name, values)
            writer.add_metadata(m.name, values)
        for a in reader.iter_attachments():
            writer.add_attachment(a.create_time, a.log_time, a.name, a.media_type, a.data)
        schemas: dict[int, int] = {}
        channels: dict[int, int] = {}
        for schema, channel, m in reader.iter_messages(log_time_order=False):
            if channel.id not in channels:
                if schema is not None and schema.id not in schemas:
                    schemas[schema.id] = writer.register_schema(
                        schema.name, schema.encoding, schema.data
                    )
                sid = 0 if schema is None else schemas[schema.id]
                channels[channel.id] = writer.register_channel(
                    channel.topic, channel.message_encoding, sid, channel.metadata
                )
            writer.add_message(channels[channel.id], m.log_time, m.data, m.publish_time, m.sequence)
        writer.finish()
    return target


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(prog="python -m tests.io.fuzz", description=__doc__)
    parser.add_argument("logs", nargs="*", type=Path)
    parser.add_argument("--mutants", type=int, default=5000, help="mutants per log")
    parser.add_argument("--workers", type=int, default=2)
    parser.add_argument("--seed", type=int, default=0, help="seed of the first mutant")
    parser.add_argument(
        "--lz4-copy",
        type=int,
        metavar="BYTES",
        help="also fuzz a copy of each log in lz4 chunks of BYTES (many chunks)",
    )
    parser.add_argument(
        "--chunk-deletions",
        type=int,
        default=0,
        metavar="N",
        help="also N mutants of each lz4 copy with one to three whole chunks deleted",
    )
    parser.add_argument(
        "--bag-mutants",
        type=int,
        default=0,
        metavar="N",
        help="also N mutants of each log's `flylog export --ros2` bag, read as a bag",
    )
    parser.add_argument("--worker", type=Path, help=argparse.SUPPRESS)
    args = parser.parse_args(argv)
    if args.worker is not None:
        worker(args.worker)
        return 0
    t0 = time.perf_counter()
    with tempfile.TemporaryDirectory(prefix="flylog-fuzz-logs-") as copies:
        targets = []
        for log in args.logs:
            # the log as flylog writes one today (its metadata checksummed), records kept
            current = rechunked(
                log, Path(copies) / log.name, chunk_size=LOG_CHUNK_SIZE, compression="zstd"
            )
            targets.append(Target(current, args.mutants))
            if args.lz4_copy:
                copy = Path(copies) / f"{log.stem}.lz4-{args.lz4_copy}.mcap"
                rechunked(log, copy, chunk_size=args.lz4_copy)
                targets.append(Target(copy, args.mutants))
                if args.chunk_deletions:
                    targets.append(Target(copy, args.chunk_deletions, mutation="chunks"))
            if args.bag_mutants:
                from flylog.ros2.export import export_ros2

                bag = export_ros2(log, Path(copies) / f"{log.stem}-bag").output
                targets.append(Target(bag / f"{bag.name}.mcap", args.bag_mutants, kind="bag"))
        counts, failures, kept = run(targets, workers=args.workers, first_seed=args.seed)
    for label, found in counts.items():
        shown = ", ".join(f"{c} {found[c]}" for c in (*ACCEPTED, *FAILURES))
        print(f"{label}: {sum(found[c] for c in (*ACCEPTED, *FAILURES))} mutants: {shown}")
        if kept[label]:
            print(
                f"  recovered reads kept {100 * np.mean(kept[label]):.1f} % of the messages; "
                f"their warnings counted the loss exactly in {found['exact']}, as a lower "
                f"bound (a cut log, a span read past) in {found['bound']}"
            )
    for f in failures[:20]:
        print(f"FAIL {f['class']}: {f['label']} seed {f['seed']} ({f['how']}): {f['detail']}")
    total = sum(sum(c[k] for k in (*ACCEPTED, *FAILURES)) for c in counts.values())
    print(f"{total} mutants in {time.perf_counter() - t0:.0f} s")
    return 1 if failures else 0


if __name__ == "__main__":
    sys.exit(main())
