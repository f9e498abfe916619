"""MCAP writing and reading speed, and log size, for each chunk compression.

A synthetic sensor log: 640×480 RGB stereo at 15 Hz, sonar at 10 Hz, odometry (+ /tf) at
50 Hz. The frames are crops of a smooth multi-octave value-noise texture that slides as
the robot moves (the right crop shifted by a disparity), with a plain shaded background
above the horizon, so they compress like a rendered scene (textured where the flies look,
plain elsewhere) rather than like white noise or a flat colour. Every view is resampled
at a sub-pixel offset, so left/right and successive frames share no exact byte runs that
a compressor could exploit unrealistically.
"""

from __future__ import annotations

import math
import time
import tracemalloc
from pathlib import Path

import cv2
import numpy as np

from flylog.geometry import Pose2D, StereoRig
from flylog.io import LogWriter, contract, encode, open_log, pair_stereo
from flylog.sensors import SonarConfig, SonarReading

SECONDS = 8.0  # simulated seconds per log
STEREO_HZ, SONAR_HZ, ODOM_HZ = 15.0, 10.0, 50.0
DISPARITY_PX = 24
HORIZON = 0.4  # fraction of the image above the horizon (untextured background)


def texture(rng: np.random.Generator, height: int, width: int) -> np.ndarray:
    """Smooth RGB value noise: octaves of upsampled random grids, 1/f weighted."""
    acc = np.zeros((height, width, 3), dtype=np.float32)
    total = 0.0
    for octave in range(1, 6):
        cells = 2 ** (octave + 1)
        coarse = rng.uniform(0, 1, (cells, int(cells * width / height) + 1, 3)).astype(np.float32)
        weight = 1.0 / octave
        acc += weight * cv2.resize(coarse, (width, height), interpolation=cv2.INTER_CUBIC)
        total += weight
    acc /= total
    lo, hi = np.percentile(acc, [1, 99])
    return np.clip((acc - lo) / (hi - lo) * 255.0, 0, 255).astype(np.uint8)


class SyntheticSensors:
    """Stereo frames cropped from a sliding texture, plus sonar and odometry."""

    def __init__(self, rng: np.random.Generator, rig: StereoRig) -> None:
        self.rig = rig
        self.rng = rng
        self.world = texture(rng, rig.height + 64, rig.width * 3)
        shade = np.linspace(0.0, 1.0, rig.height)[:, None, None]
        sky = (1 - shade) * [90, 140, 220] + shade * [200, 210, 230]
        self.sky = np.broadcast_to(sky, (rig.height, rig.width, 3)).astype(np.uint8)

    def view(self, x: float, y: float) -> np.ndarray:
        """A crop at a sub-pixel offset, slightly scaled: interpolated, so no two views
        share exact byte runs (as two renderings of a scene would not)."""
        h, w = self.rig.height, self.rig.width
        scale = 1.0 + 0.002 * math.sin(x / 50.0)
        m = np.array([[scale, 0.0, x], [0.0, scale, y]], dtype=np.float64)
        flags = cv2.INTER_LINEAR | cv2.WARP_INVERSE_MAP
        return cv2.warpAffine(self.world, m, (w, h), flags=flags, borderMode=cv2.BORDER_REFLECT)

    def stereo(self, k: int) -> tuple[np.ndarray, np.ndarray]:
        x = 20.0 + (6.37 * k) % (self.world.shape[1] - self.rig.width - 2 * DISPARITY_PX)
        y = 32.0 + 8.0 * math.sin(k / 20)
        left, right = self.view(x + DISPARITY_PX + 0.31, y), self.view(x, y)
        # Above the horizon a renderer draws a plain background: a shaded, untextured band.
        horizon = int(self.rig.height * HORIZON)
        left[:horizon] = self.sky[:horizon]
        right[:horizon] = self.sky[:horizon]
        return left, right


def write_log(path: Path, sensors: SyntheticSensors, compression: str) -> dict[str, float]:
    """Write SECONDS of sensor data: wall time encoding + writing the messages, and apart
    from it the time to close the log (finish, fsync, rename); pairs; bytes."""
    rig, sonar = sensors.rig, SonarConfig()
    events: list[tuple[int, int, str]] = []
    for rate, kind, order in (
        (STEREO_HZ, "stereo", 0),
        (SONAR_HZ, "sonar", 1),
        (ODOM_HZ, "odom", 2),
    ):
        events += [(round(k * 1e9 / rate), order, kind) for k in range(int(SECONDS * rate))]
    events.sort()
    frames = [sensors.stereo(k) for k in range(int(SECONDS * STEREO_HZ))]
    ranges = sensors.rng.uniform(0.2, 3.0, (len(events), 6))
    pairs = 0
    t0 = time.perf_counter()
    with LogWriter(path, compression=compression) as log:
        for side in ("left", "right"):
            log.write(contract.CALIBRATION_TOPICS[side], 0, encode.camera_calibration(rig, side, 0))
        log.write(contract.TF, 0, encode.frame_transforms(encode.static_transforms(rig, sonar), 0))
        for i, (t, _, kind) in enumerate(events):
            if kind == "stereo":
                left, right = frames[pairs]
                log.write(contract.LEFT_IMAGE, t, encode.raw_image(left, t, "camera_left"))
                log.write(contract.RIGHT_IMAGE, t, encode.raw_image(right, t, "camera_right"))
                pairs += 1
            elif kind == "sonar":
                reading = SonarReading(
                    t, ranges[i], sonar.mounts(), math.radians(sonar.cone_deg), sonar.max_range
                )
                log.write(contract.SONAR, t, encode.sonar_ranges(reading, min_range=0.05))
            else:
                pose = Pose2D(t * 1e-10, 0.0, t * 1e-11)
                log.write(contract.ODOM, t, encode.pose_in_frame(pose, t, contract.ODOM_FRAME))
                tf = encode.frame_transforms([encode.odom_transform(pose)], t)
                log.write(contract.TF, t, tf)
        t1 = time.perf_counter()
    t2 = time.perf_counter()
    return {"seconds": t1 - t0, "close": t2 - t1, "pairs": pairs, "bytes": path.stat().st_size}


def read_pairs(path: Path) -> tuple[float, int]:
    """Wall time to stream and decode every stereo pair of a log (sonar and odometry too)."""
    t0 = time.perf_counter()
    pairs = 0
    for m in pair_stereo(open_log(path).messages()):
        if m.topic == contract.STEREO_PAIRS:
            pairs += 1
    return time.perf_counter() - t0, pairs


def peak_read_memory(path: Path, pairs: int) -> int:
    """Peak Python-traced bytes while streaming the first ``pairs`` pairs."""
    tracemalloc.start()
    try:
        for k, _ in enumerate(open_log(path).stereo_pairs()):
            if k + 1 >= pairs:
                break
        return tracemalloc.get_traced_memory()[1]
    finally:
        tracemalloc.stop()


def run(out_dir: Path) -> list[dict]:
    rng = np.random.default_rng(0)
    sensors = SyntheticSensors(rng, StereoRig())
    figures: list[dict] = []
    per_minute = 60.0 / SECONDS
    results = {}
    for compression in ("none", "lz4", "zstd"):
        path = out_dir / f"bench_io_{compression}.mcap"
        results[compression] = w = write_log(path, sensors, compression)
        read_s, read_n = read_pairs(path)
        assert read_n == w["pairs"], (read_n, w["pairs"])
        w["read_rate"] = read_n / read_s
        if compression == "zstd":
            w["peak"] = peak_read_memory(path, 60)
        path.unlink()
    ref = results["none"]
    ref_rate = ref["pairs"] / ref["seconds"]
    for compression, w in results.items():
        rate = w["pairs"] / w["seconds"]
        row = {"reference": "none"} if compression != "none" else {}
        figures.append(
            {
                "name": f"write {compression}",
                "value": rate,
                "unit": "stereo pairs/s",
                **({**row, "ratio": rate / ref_rate} if row else {}),
                "note": f"{1000 / rate:.1f} ms per pair incl. sonar+odom+tf encode",
            }
        )
        figures.append(
            {
                "name": f"close {compression}",
                "value": w["close"] * per_minute,
                "unit": "s per minute of log",
                "note": "finish + fsync + rename, once at the end of a run",
            }
        )
        size = w["bytes"] * per_minute / 1e6
        figures.append(
            {
                "name": f"size {compression}",
                "value": size,
                "unit": "MB per minute",
                **({**row, "ratio": w["bytes"] / ref["bytes"]} if row else {}),
            }
        )
        figures.append(
            {
                "name": f"read {compression}",
                "value": w["read_rate"],
                "unit": "decoded stereo pairs/s",
                **({**row, "ratio": w["read_rate"] / ref["read_rate"]} if row else {}),
                "note": "streaming the whole log, all topics decoded",
            }
        )
    figures.append(
        {
            "name": "read zstd peak traced memory",
            "value": results["zstd"]["peak"] / 1e6,
            "unit": "MB",
            "note": f"streaming 60 pairs of a {results['zstd']['bytes'] / 1e6:.0f} MB log",
        }
    )
    return figures
