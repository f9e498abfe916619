"""The compiled ray-footprint intersection (numba), used by the renderer's kernel."""

from __future__ import annotations

import math

import numba
import numpy as np

from flylog.scene.footprints import DISC


@numba.njit(cache=True)
def ray_hit(
    kind: int,
    cx: float,
    cy: float,
    co: float,
    si: float,
    hx: float,
    hy: float,
    ox: float,
    oy: float,
    dx: float,
    dy: float,
) -> tuple[float, float, float, float]:
    """One footprint against the ray O + t·D: (t_in, t_out, nx, ny); a miss is (inf, -inf, ..)."""
    px, py = ox - cx, oy - cy
    if kind == DISC:
        a = dx * dx + dy * dy
        b = px * dx + py * dy
        c = px * px + py * py - hx * hx
        disc = b * b - a * c
        if disc < 0.0:
            return np.inf, -np.inf, 0.0, 0.0
        root = math.sqrt(disc)
        t_in, t_out = (-b - root) / a, (-b + root) / a
        if t_out <= 0.0:
            return np.inf, -np.inf, 0.0, 0.0
        return t_in, t_out, (px + t_in * dx) / hx, (py + t_in * dy) / hx
    lpx, lpy = co * px + si * py, -si * px + co * py
    ldx, ldy = co * dx + si * dy, -si * dx + co * dy
    ax = ldx if ldx != 0.0 else 1e-300
    ay = ldy if ldy != 0.0 else 1e-300
    tx1, tx2 = (-hx - lpx) / ax, (hx - lpx) / ax
    ty1, ty2 = (-hy - lpy) / ay, (hy - lpy) / ay
    txn, txf = min(tx1, tx2), max(tx1, tx2)
    tyn, tyf = min(ty1, ty2), max(ty1, ty2)
    t_in, t_out = max(txn, tyn), min(txf, tyf)
    if t_out < t_in or t_out <= 0.0:
        return np.inf, -np.inf, 0.0, 0.0
    if txn >= tyn:
        lnx, lny = -np.sign(ldx), 0.0
    else:
        lnx, lny = 0.0, -np.sign(ldy)
    return t_in, t_out, co * lnx - si * lny, si * lnx + co * lny
