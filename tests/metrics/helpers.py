"""Small sensor logs and hand-made run files with flies placed against the truth."""

from __future__ import annotations

import json
from collections.abc import Callable, Sequence
from pathlib import Path

import numpy as np

from flylog.geometry import Pose2D
from flylog.io import LogWriter, contract, encode
from flylog.io.contract import CommandStatus
from flylog.metrics.trajectory import interpolate_poses
from flylog.sim.render import Renderer
from flylog.sources.truth import LogTruth

FIXTURES = Path(__file__).resolve().parents[2] / "fixtures" / "scenes"
RULE = {"quantile": 0.5, "ground_margin": 0.05}
STRONG, WEAK = 2.0, 1.0


def true_view(truth: LogTruth, t_ns: int) -> tuple[np.ndarray, np.ndarray]:
    pose = interpolate_poses(truth.true, np.array([t_ns]))[0]
    return Renderer(truth.scene, truth.rig).render_depth(Pose2D(*pose))


def surface_flies(
    truth: LogTruth,
    t_ns: int,
    *,
    scale: float = 1.0,
    keep: Callable[[np.ndarray, np.ndarray, np.ndarray], np.ndarray] | None = None,
) -> np.ndarray:
    """(M, 3) base_link points on every obstacle pixel of the true view (depth × scale),
    optionally only those where ``keep(u, v, ids)`` holds."""
    depth, ids = true_view(truth, t_ns)
    v, u = np.nonzero(ids >= 0)
    if keep is not None:
        chosen = keep(u, v, ids[v, u])
        u, v = u[chosen], v[chosen]
    return truth.rig.backproject(u, v, depth[v, u] * scale)


def with_weak_flies(strong: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """The strong flies plus as many weak ones (at least 10; high above, out of view): with
    the 0.5 quantile rule only strong ones are obstacle flies. (Never an empty cloud: the
    io decoder does not read one.)"""
    weak = np.tile([[0.5, 0.0, 50.0]], (max(len(strong), 10), 1))
    xyz = np.concatenate([strong, weak]).astype(np.float32)
    fitness = np.concatenate([np.full(len(strong), STRONG), np.full(len(weak), WEAK)])
    return xyz, fitness.astype(np.float32)


def write_run(
    path: Path,
    snapshots: Sequence[tuple[int, np.ndarray]],
    *,
    metadata: dict[str, str] | None = None,
    paths: Sequence[tuple[int, np.ndarray]] = (),
    statuses: Sequence[tuple[int, CommandStatus]] = (),
    odom: Sequence[tuple[int, Pose2D]] = (),
) -> Path:
    """A run file: /flies (obstacle flies plus as many weak ones), /planner/path,
    /planner/command, /tf odom → base_link, and ``flylog.replay`` metadata."""
    events: list[tuple[int, int, str, object]] = []
    for t, strong in snapshots:
        xyz, fitness = with_weak_flies(strong)
        events.append((t, 0, contract.FLIES, encode.point_cloud(xyz, fitness, t, "base_link")))
    for t, poses in paths:
        events.append((t, 1, contract.PLANNER_PATH, encode.poses_in_frame(poses, t, "odom")))
    for t, status in statuses:
        events.append((t, 2, contract.PLANNER_COMMAND, encode.command(0.1, 0.0, status, t)))
    for t, pose in odom:
        tf = encode.frame_transforms([encode.odom_transform(pose)], t)
        events.append((t, 3, contract.TF, tf))
    events.sort(key=lambda e: (e[0], e[1]))
    meta = {
        "config": json.dumps({"engine": {"flies": 100}, "obstacles": RULE}),
        "generations": "120",
        "evaluations": "60000",
        "wall_seconds": "3.0",
        "log_duration": "2.0",
    }
    with LogWriter(path) as log:
        log.add_metadata(contract.REPLAY_METADATA, metadata if metadata is not None else meta)
        for t, _, topic, message in events:
            log.write(topic, t, message)
    return path
