"""A planar trajectory: poses (x, y, theta) at log times, as every input gives them (the
true pose, the odometry, the planner's path) and the metrics score them."""

from __future__ import annotations

from typing import NamedTuple

import numpy as np


class Trajectory(NamedTuple):
    """Planar poses in time order: times (N,) int64 ns and poses (N, 3) x, y, theta."""

    t_ns: np.ndarray
    xyt: np.ndarray

    def __len__(self) -> int:
        return int(self.t_ns.shape[0])

    @property
    def xy(self) -> np.ndarray:
        return self.xyt[:, :2]


def trajectory(t_ns: list[int] | np.ndarray, xyt: list[tuple] | np.ndarray) -> Trajectory:
    """A Trajectory from lists, sorted by time (stable)."""
    t = np.asarray(t_ns, dtype=np.int64).reshape(-1)
    p = np.asarray(xyt, dtype=float).reshape(-1, 3)
    order = np.argsort(t, kind="stable")
    return Trajectory(t[order], p[order])
