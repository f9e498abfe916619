"""Opening a ROS 2 bag: a single ``.mcap`` file with the ``ros2`` profile, or a rosbag2
directory (``metadata.yaml`` and its MCAP files, read in the order it lists them).

The MCAP files are streamed by flylog's own reader (:mod:`flylog.io.reader`): chunk by chunk
through the index, or front to back up to the damage of a cut file with a
TruncatedLogWarning, in the same log-time order as a flylog log. CDR messages are decoded
by ``rosbags`` with types built from the bag's own ``ros2msg`` schemas.
"""

from __future__ import annotations

import os
from collections.abc import Iterable, Iterator
from pathlib import Path
from typing import Any, NamedTuple

from mcap.reader import SeekingReader

from flylog.errors import LogError
from flylog.io.inputs import input_path, open_input, read_input_text
from flylog.io.reader import open_log
from flylog.io.records import TopicInfo
from flylog.ros2.detect import ROS1_MAGIC, ROS2_PROFILE
from flylog.ros2.frames import StaticTree
from flylog.ros2.types import TF_STATIC, CdrDecoder

METADATA_FILE = "metadata.yaml"


class BagMessage(NamedTuple):
    """One decoded message of a bag: its topic, log (receive) time, ROS type and value."""

    topic: str
    log_time_ns: int
    msgtype: str
    value: Any


class Bag:
    """A ROS 2 bag opened for reading; each :meth:`messages` opens its own file handles."""

    def __init__(self, path: Path, files: list[Path], custom: dict[str, str]) -> None:
        self.path = path
        self.files = files
        self.custom = custom  # metadata.yaml's custom_data (a single file has none)
        self._readers = [open_log(f) for f in files]
        for reader in self._readers:
            _check_profile(reader.path)
        self._decoder = CdrDecoder(path)
        self._topics: dict[str, TopicInfo] | None = None

    def topics(self) -> dict[str, TopicInfo]:
        """topic → (ROS type, message count) over every file, for topics with messages."""
        if self._topics is None:
            out: dict[str, TopicInfo] = {}
            for reader in self._readers:
                for topic, info in reader.topics().items():
                    count = out[topic].count if topic in out else 0
                    out[topic] = TopicInfo(info.schema, count + info.count)
            self._topics = dict(sorted(out.items()))
        return dict(self._topics)

    @property
    def start_ns(self) -> int:
        starts = [r.start_ns for r in self._readers if r.topics()]
        return min(starts) if starts else 0

    @property
    def end_ns(self) -> int:
        ends = [r.end_ns for r in self._readers if r.topics()]
        return max(ends) if ends else 0

    def messages(self, topics: Iterable[str] | None = None) -> Iterator[BagMessage]:
        """Decoded messages of ``topics`` (all if None), file after file, each in log-time
        order; LogError naming the bag, the topic and the time for a message that does not
        decode."""
        wanted = None if topics is None else sorted(set(topics))
        for reader in self._readers:
            for raw in reader.raw_messages(wanted):
                channel = raw.channel
                schema = raw.schema
                value = self._decoder.decode(channel.topic, schema, raw.message, channel)
                yield BagMessage(
                    channel.topic, raw.message.log_time, schema.name if schema else "", value
                )


def static_tree(bag: Bag) -> StaticTree:
    """The transforms of the bag's /tf_static (an empty tree without it)."""
    tree = StaticTree()
    if TF_STATIC in bag.topics():
        for m in bag.messages([TF_STATIC]):
            tree.add(m.value)
    return tree


def open_bag(path: str | os.PathLike[str]) -> Bag:
    """Open a ROS 2 bag; LogError for a ROS 1 bag, a directory without ``metadata.yaml``,
    a storage other than MCAP, or a file listed but absent."""
    path = Path(path)
    if path.is_dir():
        input_path(path, "the bag", directory=True)
        files, custom = _directory_files(path)
        return Bag(path, files, custom)
    if not path.exists():
        msg = f"{path}: no such file or directory"
        raise LogError(msg)
    with open_input(path, "the bag") as fh:
        if fh.read(len(ROS1_MAGIC)) == ROS1_MAGIC:
            msg = (
                f"{path} is a ROS 1 bag, which flylog does not read: convert it to a ROS 2 "
                f"bag first (e.g. `rosbags-convert --src {path.name}`)"
            )
            raise LogError(msg)
    return Bag(path, [path], {})


def _check_profile(path: Path) -> None:
    with open_input(path, "the bag's file") as fh:
        try:
            profile = SeekingReader(fh).get_header().profile
        except Exception as exc:
            msg = f"{path}: no readable MCAP header ({type(exc).__name__}: {exc})"
            raise LogError(msg) from None
    if profile != ROS2_PROFILE:
        msg = f"{path} has MCAP profile '{profile}', not '{ROS2_PROFILE}': it is not a ROS 2 bag"
        raise LogError(msg)


def _directory_files(path: Path) -> tuple[list[Path], dict[str, str]]:
    """The MCAP files of a rosbag2 directory in the order metadata.yaml lists them, and
    its custom_data."""
    from ruamel.yaml import YAML, YAMLError  # rosbags' YAML library

    meta_path = path / METADATA_FILE
    if not meta_path.is_file():
        found = ", ".join(sorted(p.name for p in path.iterdir())) or "nothing"
        msg = (
            f"{path} is a directory without {METADATA_FILE}, so not a rosbag2 bag (it holds "
            f"{found}); give one of its .mcap files instead, or the bag's directory"
        )
        raise LogError(msg)
    try:
        doc = YAML(typ="safe").load(read_input_text(meta_path, "the bag's metadata"))
        info = doc["rosbag2_bagfile_information"]
        storage = str(info.get("storage_identifier", ""))
        names = [str(p) for p in info["relative_file_paths"]]
        custom = {str(k): str(v) for k, v in (info.get("custom_data") or {}).items()}
        compressed = str(info.get("compression_mode", "") or "").lower() not in ("", "none")
    except (OSError, YAMLError, KeyError, TypeError, AttributeError) as exc:
        msg = f"{meta_path}: not a rosbag2 metadata file ({type(exc).__name__}: {exc})"
        raise LogError(msg) from None
    if storage != "mcap":
        msg = f"{meta_path}: storage '{storage}' is not supported; flylog reads MCAP bags only"
        raise LogError(msg)
    if compressed:
        msg = (
            f"{meta_path}: file-compressed bags are not supported; record with MCAP's "
            f"chunk compression instead (storage-level compression is read)"
        )
        raise LogError(msg)
    files = [path / Path(name).name for name in names]
    missing = [f.name for f in files if not f.is_file()]
    if missing:
        msg = f"{meta_path} lists {', '.join(missing)}, which {path} does not hold"
        raise LogError(msg)
    if not files:
        msg = f"{meta_path} lists no files"
        raise LogError(msg)
    return files, custom
