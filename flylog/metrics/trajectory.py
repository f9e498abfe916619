"""Trajectory metrics over planar pose arrays: evo's APE/RPE in SE(2), path length, goal.

Poses are ``(N, 3)`` arrays of x (m), y (m), theta (rad) with ``(N,)`` int64 times (ns).

- ATE (``evo_ape --align``, translation part): RMSE of the position differences after the
  least-squares rigid alignment of the estimate onto the reference (Umeyama without scale;
  rotation about z and a 2-D translation, since both trajectories are planar).
- RPE (``evo_rpe --delta``, translation and rotation parts): over the pose pairs
  (i, j) of the reference with j the first pose at least ``delta`` seconds after i, taken
  one after another (i₀ = 0, i₁ = j₀, … as evo's default, non-overlapping pairs), the error
  E = (Qᵢ⁻¹Qⱼ)⁻¹(Pᵢ⁻¹Pⱼ); RMSE of |t(E)| and of |angle(E)|. A rigid alignment does not
  change relative poses, so RPE needs none.
"""

from __future__ import annotations

import numpy as np

from flylog.sources.trajectory import Trajectory


def wrap(angles: np.ndarray) -> np.ndarray:
    """Angles in (-pi, pi]."""
    return np.arctan2(np.sin(angles), np.cos(angles))


class PoseInterpolator:
    """``interpolate_poses`` for many queries on one trajectory (the heading unwrapped once)."""

    def __init__(self, traj: Trajectory) -> None:
        self._t = traj.t_ns
        self._x, self._y = traj.xyt[:, 0], traj.xyt[:, 1]
        self._theta = np.unwrap(traj.xyt[:, 2])

    def __call__(self, t_ns: np.ndarray) -> np.ndarray:
        t = np.asarray(t_ns, dtype=np.int64)
        x = np.interp(t, self._t, self._x)
        y = np.interp(t, self._t, self._y)
        theta = np.interp(t, self._t, self._theta)
        return np.stack([x, y, wrap(theta)], axis=-1)


def interpolate_poses(traj: Trajectory, t_ns: np.ndarray) -> np.ndarray:
    """(M, 3) poses at the query times: linear in x, y and in the unwrapped heading,
    clamped to the end poses outside the trajectory's time span."""
    return PoseInterpolator(traj)(t_ns)


def associate(
    t_ref: np.ndarray, t_est: np.ndarray, max_diff_ns: int
) -> tuple[np.ndarray, np.ndarray]:
    """Indices (i_ref, i_est) of matched times: each reference time with the nearest
    estimate time, kept if they differ by at most ``max_diff_ns`` (evo's association)."""
    t_ref, t_est = np.asarray(t_ref, np.int64), np.asarray(t_est, np.int64)
    if len(t_ref) == 0 or len(t_est) == 0:
        empty = np.empty(0, dtype=np.int64)
        return empty, empty
    right = np.clip(np.searchsorted(t_est, t_ref), 0, len(t_est) - 1)
    left = np.clip(right - 1, 0, len(t_est) - 1)
    pick_left = np.abs(t_ref - t_est[left]) <= np.abs(t_est[right] - t_ref)
    nearest = np.where(pick_left, left, right)
    keep = np.abs(t_est[nearest] - t_ref) <= max_diff_ns
    return np.flatnonzero(keep), nearest[keep]


def align_se2(ref_xy: np.ndarray, est_xy: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """(R (2, 2), t (2,)) minimising Σ|ref − (R·est + t)|² (Umeyama, no scale)."""
    mu_r, mu_e = ref_xy.mean(axis=0), est_xy.mean(axis=0)
    cov = (ref_xy - mu_r).T @ (est_xy - mu_e) / len(ref_xy)
    u, _, vt = np.linalg.svd(cov)
    s = np.diag([1.0, np.sign(np.linalg.det(u) * np.linalg.det(vt)) or 1.0])
    rot = u @ s @ vt
    return rot, mu_r - rot @ mu_e


def ate_rmse(ref_xy: np.ndarray, est_xy: np.ndarray, *, align: bool = True) -> float:
    """Absolute trajectory error (m): RMSE of matched positions, after alignment."""
    if len(ref_xy) == 0:
        return float("nan")
    if align and len(ref_xy) >= 2:
        rot, t = align_se2(ref_xy, est_xy)
        est_xy = est_xy @ rot.T + t
    return float(np.sqrt(np.mean(np.sum((ref_xy - est_xy) ** 2, axis=1))))


def relative_poses(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """Row-wise a⁻¹ ⊕ b for (N, 3) pose arrays: b expressed in a's frame."""
    dx, dy = b[:, 0] - a[:, 0], b[:, 1] - a[:, 1]
    c, s = np.cos(a[:, 2]), np.sin(a[:, 2])
    return np.stack([c * dx + s * dy, -s * dx + c * dy, wrap(b[:, 2] - a[:, 2])], axis=1)


def rpe_pairs(t_ns: np.ndarray, delta_ns: int) -> tuple[np.ndarray, np.ndarray]:
    """Indices (i, j) of consecutive, non-overlapping pairs at least ``delta_ns`` apart."""
    starts, ends = [], []
    i = 0
    n = len(t_ns)
    while i < n:
        j = int(np.searchsorted(t_ns, t_ns[i] + delta_ns, side="left"))
        if j >= n:
            break
        starts.append(i)
        ends.append(j)
        i = j
    return np.array(starts, dtype=np.int64), np.array(ends, dtype=np.int64)


def rpe_rmse(
    t_ns: np.ndarray, ref: np.ndarray, est: np.ndarray, *, delta_s: float
) -> tuple[float, float]:
    """Relative pose error over ``delta_s``: (translation RMSE m, rotation RMSE rad); NaN
    if the trajectory is shorter than ``delta_s``."""
    i, j = rpe_pairs(np.asarray(t_ns, dtype=np.int64), round(delta_s * 1e9))
    if len(i) == 0:
        return float("nan"), float("nan")
    err = relative_poses(relative_poses(ref[i], ref[j]), relative_poses(est[i], est[j]))
    trans = float(np.sqrt(np.mean(err[:, 0] ** 2 + err[:, 1] ** 2)))
    rot = float(np.sqrt(np.mean(err[:, 2] ** 2)))
    return trans, rot


def path_length(xy: np.ndarray) -> float:
    """Length (m) of the polyline through the positions."""
    return float(np.sum(np.linalg.norm(np.diff(xy, axis=0), axis=1)))


def count_entries(inside: np.ndarray) -> int:
    """How many times a boolean sequence turns True (a True start counts as one)."""
    inside = np.asarray(inside, dtype=bool)
    if len(inside) == 0:
        return 0
    return int(inside[0]) + int(np.count_nonzero(inside[1:] & ~inside[:-1]))


def first_arrival(traj: Trajectory, goal: tuple[float, float], tolerance: float) -> int | None:
    """Index of the first pose within ``tolerance`` of ``goal``, None if never."""
    near = np.hypot(traj.xyt[:, 0] - goal[0], traj.xyt[:, 1] - goal[1]) <= tolerance
    hits = np.flatnonzero(near)
    return int(hits[0]) if len(hits) else None
