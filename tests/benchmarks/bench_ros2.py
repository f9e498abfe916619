"""ROS 2 bags: reading speed against a flylog log of the same frames, replay of an export
against replay of the log, and the reader's peak memory over two bag lengths.

Reading: the synthetic 640×480 stereo of bench_io (15 Hz, with sonar and odometry at
10 and 50 Hz) written as a flylog log, exported as rosbag2 bags with rgb8, png and jpeg
images; decoded stereo pairs per second through each input's whole record stream (what
replay reads). Replay: bench_replay's reference log (corridor 640×480 @ 15 Hz, 60 s) and
its rgb8 export (1.7 GB), each replayed once with the reference configuration.
"""

from __future__ import annotations

import math
import time
import tracemalloc
from pathlib import Path

import numpy as np

from flylog.geometry import Pose2D, StereoRig
from flylog.io import LogWriter, contract, encode, open_log, pair_stereo
from flylog.replay.run import replay
from flylog.ros2.config import BagOptions
from flylog.ros2.export import export_ros2
from flylog.ros2.messages import ImageFormat
from flylog.ros2.source import BagSource
from flylog.sensors import SonarConfig, SonarReading
from flylog.sources.inputs import SENSOR_TOPICS
from tests.benchmarks.bench_io import ODOM_HZ, SONAR_HZ, STEREO_HZ, SyntheticSensors
from tests.benchmarks.bench_replay import REFERENCE, _log, reference_log

READ_SECONDS = 8.0
MEMORY_SECONDS = (4.0, 16.0)


def synthetic_log(path: Path, sensors: SyntheticSensors, seconds: float) -> Path:
    """A flylog sensor log of ``seconds`` of bench_io's synthetic sensors."""
    rig, sonar = sensors.rig, SonarConfig()
    events = sorted(
        (round(k * 1e9 / rate), order, kind)
        for rate, kind, order in (
            (STEREO_HZ, "stereo", 0),
            (SONAR_HZ, "sonar", 1),
            (ODOM_HZ, "odom", 2),
        )
        for k in range(int(seconds * rate))
    )
    ranges = sensors.rng.uniform(0.2, 3.0, (len(events), 6))
    frame = 0
    with LogWriter(path) as log:
        for side in ("left", "right"):
            log.write(contract.CALIBRATION_TOPICS[side], 0, encode.camera_calibration(rig, side, 0))
        log.write(contract.TF, 0, encode.frame_transforms(encode.static_transforms(rig, sonar), 0))
        for i, (t, _, kind) in enumerate(events):
            if kind == "stereo":
                left, right = sensors.stereo(frame)
                frame += 1
                log.write(contract.LEFT_IMAGE, t, encode.raw_image(left, t, "camera_left"))
                log.write(contract.RIGHT_IMAGE, t, encode.raw_image(right, t, "camera_right"))
            elif kind == "sonar":
                cone = math.radians(sonar.cone_deg)
                reading = SonarReading(t, ranges[i], sonar.mounts(), cone, sonar.max_range)
                log.write(contract.SONAR, t, encode.sonar_ranges(reading, min_range=0.05))
            else:
                pose = Pose2D(t * 1e-10, 0.0, t * 1e-11)
                log.write(contract.ODOM, t, encode.pose_in_frame(pose, t, contract.ODOM_FRAME))
                log.write(contract.TF, t, encode.frame_transforms([encode.odom_transform(pose)], t))
    return path


def log_pairs_per_second(path: Path) -> float:
    t0 = time.perf_counter()
    pairs = sum(
        m.topic == contract.STEREO_PAIRS
        for m in pair_stereo(open_log(path).messages(SENSOR_TOPICS))
    )
    return pairs / (time.perf_counter() - t0)


def bag_pairs_per_second(path: Path) -> float:
    t0 = time.perf_counter()
    source = BagSource(path, BagOptions())
    pairs = sum(m.topic == contract.STEREO_PAIRS for m in source.records())
    return pairs / (time.perf_counter() - t0)


def peak_streaming_memory(path: Path) -> int:
    """Peak Python-traced bytes while streaming every record of a bag."""
    tracemalloc.start()
    try:
        for _ in BagSource(path, BagOptions()).records():
            pass
        return tracemalloc.get_traced_memory()[1]
    finally:
        tracemalloc.stop()


def _reading(out_dir: Path) -> list[dict]:
    sensors = SyntheticSensors(np.random.default_rng(0), StereoRig())
    log = synthetic_log(out_dir / "bench_ros2_read.mcap", sensors, READ_SECONDS)
    reference = log_pairs_per_second(log)
    figures = [
        {
            "name": "read flylog log 640x480 (reference)",
            "value": reference,
            "unit": "decoded stereo pairs/s",
            "note": "all sensor topics streamed, images paired",
        }
    ]
    for fmt in (ImageFormat.RGB8, ImageFormat.PNG, ImageFormat.JPEG):
        bag = export_ros2(log, out_dir / f"bench_ros2_read_{fmt.value}", image_format=fmt).output
        rate = bag_pairs_per_second(bag)
        size = sum(f.stat().st_size for f in bag.iterdir()) / 1e6
        figures.append(
            {
                "name": f"read ROS 2 bag 640x480 {fmt.value}",
                "value": rate,
                "unit": "decoded stereo pairs/s",
                "reference": "the flylog log of the same frames",
                "ratio": rate / reference,
                "note": f"{size:.0f} MB for {READ_SECONDS:g} s; CDR decoded, images converted",
            }
        )
        _remove(bag)
    log.unlink()
    return figures


def _replay(out_dir: Path) -> list[dict]:
    log = reference_log(out_dir)
    bag = out_dir / "bench_ros2_corridor_rgb8"
    _remove(bag)
    export_ros2(log, bag)
    replay(_log(out_dir, "corridor", 1.0), out_dir / "bench_ros2_warm.mcap", REFERENCE)
    of_log = replay(log, out_dir / "bench_ros2_log_run.mcap", REFERENCE)
    of_bag = replay(bag, out_dir / "bench_ros2_bag_run.mcap", REFERENCE)
    _remove(bag)
    return [
        {
            "name": "replay ROS 2 export of the reference log (corridor 640x480, 60 s)",
            "value": of_bag.wall_seconds,
            "unit": "s wall",
            "reference": "replay of the flylog log",
            "ratio": of_bag.wall_seconds / of_log.wall_seconds,
            "note": f"log {of_log.wall_seconds:.1f} s; {of_bag.generations} and "
            f"{of_log.generations} generations",
        }
    ]


def _memory(out_dir: Path) -> list[dict]:
    sensors = SyntheticSensors(np.random.default_rng(1), StereoRig())
    figures, peaks = [], []
    for seconds in MEMORY_SECONDS:
        log = synthetic_log(out_dir / "bench_ros2_mem.mcap", sensors, seconds)
        bag = export_ros2(log, out_dir / "bench_ros2_mem").output
        log.unlink()
        peaks.append(peak_streaming_memory(bag))
        _remove(bag)
        figures.append(
            {
                "name": f"bag reading peak traced memory, {seconds:g} s bag",
                "value": peaks[-1] / 1e6,
                "unit": "MB",
                **(
                    {"reference": f"{MEMORY_SECONDS[0]:g} s bag", "ratio": peaks[-1] / peaks[0]}
                    if len(peaks) > 1
                    else {}
                ),
                "note": "every record of a 640x480 rgb8 bag streamed",
            }
        )
    return figures


def _remove(bag: Path) -> None:
    if bag.is_dir():
        for f in bag.iterdir():
            f.unlink()
        bag.rmdir()


def run(out_dir: Path) -> list[dict]:
    return _reading(out_dir) + _memory(out_dir) + _replay(out_dir)
