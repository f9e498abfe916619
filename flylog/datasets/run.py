"""``flylog import FORMAT PATH -o OUT``: a dataset folder → one flylog log per scene or pair.

Every source is checked (layout, calibration) before any log is written, and the logs are
published together (:class:`flylog.io.atomic.Batch`) once the last is complete: a failure or
a stop signal while writing leaves every file the import found as it found it (an earlier
import's logs of the same names included) and nothing new behind.
"""

from __future__ import annotations

import itertools
from collections.abc import Callable, Iterator
from dataclasses import dataclass
from pathlib import Path

from flylog.datasets import euroc, kitti, middlebury
from flylog.datasets.logwrite import DatasetFrame, Source, write_dataset_log
from flylog.errors import LogError
from flylog.io import contract
from flylog.io.atomic import Batch

# format name → the function listing a folder's sources
LAYOUTS: dict[str, Callable[[Path], list[Source]]] = {
    "middlebury": middlebury.sources,
    "kitti": kitti.sources,
    "euroc": euroc.sources,
}


@dataclass(frozen=True)
class ImportedLog:
    path: Path
    source: Path
    frames: int


def _limited(frames: Iterator[DatasetFrame], limit: int | None) -> Iterator[DatasetFrame]:
    return frames if limit is None else itertools.islice(frames, limit)


def import_dataset(
    layout: str,
    path: Path,
    output: Path,
    *,
    scene: str | None = None,
    limit: int | None = None,
    multiview: bool = False,
    on_progress: Callable[[float, float], None] | None = None,
) -> list[ImportedLog]:
    """Import the dataset at ``path`` in ``layout``. One source: ``output`` is the log (a
    folder there: ``output/NAME.mcap``); several: ``output`` is a folder (made if absent)
    holding ``NAME.mcap`` for each. ``scene`` keeps the source of that name, ``limit`` the
    first frames of each; ``multiview`` imports the KITTI stereo benchmarks' multiview
    frames (00 … 20) of each scene as a sequence log. ``on_progress(done, total)`` counts
    sources (logs) written."""
    if layout not in LAYOUTS:
        msg = f"unknown dataset format '{layout}': one of {', '.join(sorted(LAYOUTS))}"
        raise LogError(msg)
    path, output = Path(path), Path(output)
    if multiview and layout != "kitti":
        msg = f"{path}: multiview frames are KITTI's stereo benchmarks'; {layout} has none"
        raise LogError(msg)
    found = kitti.sources(path, multiview=True) if multiview else LAYOUTS[layout](path)
    if scene is not None:
        names = [s.name for s in found]
        found = [s for s in found if s.name == scene]
        if not found:
            msg = f"{path}: no scene '{scene}' (it holds {', '.join(names)})"
            raise LogError(msg)
    if len(found) == 1 and not output.is_dir():
        targets = [output]
    else:
        if output.exists() and not output.is_dir():
            msg = f"{output}: {path} holds {len(found)} scenes; -o must be a folder for them"
            raise LogError(msg)
        targets = [output / f"{s.name}.mcap" for s in found]
    made_dir = not output.exists() and len(targets) > 1
    if made_dir:
        output.mkdir(parents=True)
    written: list[ImportedLog] = []
    try:
        with Batch() as batch:
            for source, target in zip(found, targets, strict=True):
                meta = {
                    "format": layout,
                    "source": str(source.path),
                    "scene": source.name,
                    "mount": "dataset" if source.mount else contract.MOUNT_NONE,
                }
                frames = write_dataset_log(
                    target, source.rig, _limited(source.frames(), limit), meta, batch=batch
                )
                written.append(ImportedLog(target, source.path, frames))
                if on_progress is not None:
                    on_progress(len(written), len(found))
    except BaseException:
        if made_dir and not any(output.iterdir()):
            output.rmdir()
        raise
    return written
