"""The true depth D and obstacle id each fly is judged against, looked up in true views
rendered in k×k pixel blocks (:mod:`flylog.metrics.view`); :mod:`flylog.metrics.flies`
defines the scores that read them."""

from __future__ import annotations

import numpy as np


def relative_depth_error(d: np.ndarray, true_d: np.ndarray) -> np.ndarray:
    """|d − D| / D, inf where D is not finite (the sky)."""
    with np.errstate(invalid="ignore"):
        return np.where(np.isfinite(true_d), np.abs(d - true_d) / true_d, np.inf)


def _one_surface(ids: np.ndarray, s: np.ndarray, i: np.ndarray, j: np.ndarray) -> np.ndarray:
    """Whether the centres of blocks (i..i+1, j..j+1) of view ``s`` all see one obstacle,
    or all the ground."""
    first = ids[s, i, j]
    one = (first >= -1) & (ids[s, i, j + 1] == first) & (ids[s, i + 1, j] == first)
    one &= ids[s, i + 1, j + 1] == first
    return one


def _inverse_at(depth: np.ndarray, s: np.ndarray, i: np.ndarray, j: np.ndarray) -> np.ndarray:
    with np.errstate(divide="ignore"):
        return 1.0 / depth[s, i, j].astype(float)


def _inverse_bilinear(
    depth: np.ndarray,
    s: np.ndarray,
    i: np.ndarray,
    j: np.ndarray,
    fy: np.ndarray,
    fx: np.ndarray,
) -> np.ndarray:
    """1/D interpolated (or extrapolated) bilinearly between block centres (i..i+1, j..j+1)
    of view ``s`` of the stacked views, at offsets (fy, fx) from centre (i, j), in blocks."""
    top = (1 - fx) * _inverse_at(depth, s, i, j) + fx * _inverse_at(depth, s, i, j + 1)
    bottom = (1 - fx) * _inverse_at(depth, s, i + 1, j) + fx * _inverse_at(depth, s, i + 1, j + 1)
    return (1 - fy) * top + fy * bottom


def views_at(
    depth: np.ndarray,
    ids: np.ndarray,
    s: np.ndarray,
    iu: np.ndarray,
    iv: np.ndarray,
    d: np.ndarray,
    tau: float,
    block: int = 1,
) -> tuple[np.ndarray, np.ndarray]:
    """:func:`view_at` for flies of several snapshots: fly k is judged
    against view ``s[k]`` of the stacked views ``depth``, ``ids`` (S, H/block, W/block)."""
    own_i, own_j = iv // block, iu // block
    true_d = depth[s, own_i, own_j].astype(float)
    hit = ids[s, own_i, own_j]
    rows, cols = depth.shape[1:]
    if block == 1 or rows < 2 or cols < 2:
        return true_d, hit
    y, x = (iv - (block - 1) / 2.0) / block, (iu - (block - 1) / 2.0) / block
    i0 = np.clip(np.floor(y).astype(np.int64), 0, rows - 2)
    j0 = np.clip(np.floor(x).astype(np.int64), 0, cols - 2)
    inv = _inverse_bilinear(depth, s, i0, j0, y - i0, x - j0)
    inside = _one_surface(ids, s, i0, j0) & (inv > 0)
    true_d[inside] = 1.0 / inv[inside]
    near = np.flatnonzero(~inside)
    if len(near) == 0:
        return true_d, hit
    # The 3×3 windows around each distinct (snapshot, pixel) near a boundary.
    width = cols * block
    key = (s[near] * (rows * block) + iv[near]) * width + iu[near]
    pixels, fly_pixel = np.unique(key, return_inverse=True)
    first_fly = np.zeros(len(pixels), dtype=np.int64)
    first_fly[fly_pixel] = near
    ps = s[first_fly][None, :]
    pi, pj, py, px = i0[first_fly], j0[first_fly], y[first_fly], x[first_fly]
    oi, oj = own_i[first_fly], own_j[first_fly]
    di, dj = np.repeat([-1, 0, 1], 3)[:, None], np.tile([-1, 0, 1], 3)[:, None]
    i = np.clip(pi[None, :] + di, 0, rows - 2)
    j = np.clip(pj[None, :] + dj, 0, cols - 2)
    inv = _inverse_bilinear(depth, ps, i, j, py - i, px - j)
    usable = _one_surface(ids, ps, i, j) & (inv > 0)
    candidate = 1.0 / np.where(usable, inv, 1.0)
    holds_own = (i <= oi) & (oi <= i + 1) & (j <= oj) & (oj <= j + 1)
    rank = np.where(usable & holds_own, np.abs(di) + np.abs(dj), 9)
    own = np.argmin(rank, axis=0)
    p = np.arange(len(pixels))
    has_own = (rank[own, p] < 9)[fly_pixel]
    true_d[near[has_own]] = candidate[own, p][fly_pixel][has_own]
    err = np.where(
        usable[:, fly_pixel], relative_depth_error(d[near], candidate[:, fly_pixel]), np.inf
    )
    best = np.argmin(err, axis=0)
    n = np.arange(len(near))
    matched = (err[best, n] <= tau) & (err[best, n] < relative_depth_error(d[near], true_d[near]))
    window_ids = ids[ps, i, j][:, fly_pixel]
    true_d[near[matched]] = candidate[:, fly_pixel][best, n][matched]
    hit[near[matched]] = window_ids[best, n][matched]
    return true_d, hit


def view_at(
    depth: np.ndarray,
    ids: np.ndarray,
    iu: np.ndarray,
    iv: np.ndarray,
    d: np.ndarray,
    tau: float,
    block: int = 1,
) -> tuple[np.ndarray, np.ndarray]:
    """(true depth D, id) that flies at depths ``d`` projecting to full-image pixels (``iu``,
    ``iv``) are judged against, from a view given in ``block``-pixel blocks.

    Within one surface (2×2 block centres all seeing the same obstacle, or all the ground)
    D is interpolated between block centres bilinearly in 1/D, which is exact on a plane (a
    face, a top, the ground: 1/D is affine in the pixel coordinates there). A pixel whose
    2×2 surrounding centres see one surface sees it. A pixel near a boundary (they do not)
    sees its own block's surface, its D extrapolated (by at most 1.5 blocks) from the
    nearest 2×2 window holding its block that sees one surface (else the block's own
    value); but it may as well see the other side: a fly whose depth is within ``tau`` of
    another surface of the 3×3 neighbouring windows is judged against the one it matches
    best. With ``block`` = 1, the pixel's own values."""
    s = np.zeros(len(iu), dtype=np.int64)
    return views_at(depth[None], ids[None], s, iu, iv, d, tau, block)
