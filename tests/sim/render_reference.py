"""Plain-numpy reference of :meth:`flylog.sim.render.Renderer.render` for a level rig (slow,
for tests at small sizes)."""

from __future__ import annotations

import numpy as np

from flylog.geometry import Pose2D, StereoRig
from flylog.scene.footprints import DISC, ray_hits_numpy
from flylog.scene.load import Scene
from flylog.sim.render import (
    _MIN_INCIDENCE_COS,
    RenderedPair,
    _camera_rays,
    _cyclopean_centre,
    _scene_arrays,
    sky_pattern,
)
from flylog.sim.textures import texture_value_numpy


def render_reference(
    scene: Scene, rig: StereoRig, pose: Pose2D, rows: tuple[int, int] | None = None
) -> RenderedPair:
    """Plain-numpy reference of :meth:`Renderer.render`: every candidate surface of every
    pixel is computed and the nearest taken (no sorting, no early exit). ``rows``: only
    the rows [first, stop), as an image of stop - first rows."""
    first, stop = rows if rows is not None else (0, rig.height)
    height = stop - first
    a = _scene_arrays(scene)
    fp = a.fp
    n = len(fp)
    slope = (np.arange(first, stop) - rig.cy) / rig.focal_px
    hc = rig.mount_height
    down = slope > 0.0
    with np.errstate(divide="ignore"):
        t_ground = np.where(down, hc / np.where(down, slope, 1.0), np.inf)
    images, depth0, ids0 = [], None, None
    centre = _cyclopean_centre(rig, pose)
    for side in ("left", "right"):
        ox, oy, dirs = _camera_rays(rig, pose, side)
        sky_cols, sky_rows = sky_pattern(rig, dirs[None], a.sky[3])
        sky_rows = sky_rows[first:stop]
        img = np.empty((height, rig.width, 3), dtype=np.uint8)
        depth = np.empty((height, rig.width))
        ids = np.empty((height, rig.width), dtype=np.int64)
        for u in range(rig.width):
            dx, dy = dirs[u]
            t_in, t_out, nxs, nys = ray_hits_numpy(fp, ox, oy, dx, dy)
            z_in = hc - slope[:, None] * t_in[None, :]
            side_ok = (t_in > 0.0) & (z_in >= 0.0) & (z_in <= fp.height)
            t_side = np.where(side_ok, t_in, np.inf)
            with np.errstate(divide="ignore", invalid="ignore"):
                t_top = (hc - fp.height[None, :]) / slope[:, None]
            top_ok = (
                down[:, None]
                & (hc > fp.height)
                & (t_top >= np.maximum(t_in, 0.0))
                & (t_top <= t_out)
            )
            t_top = np.where(top_ok, t_top, np.inf)
            cand = np.concatenate([t_ground[:, None], t_side, t_top], axis=1)  # (H, 1 + 2n)
            pick = np.argmin(cand, axis=1)
            best = cand[np.arange(height), pick]
            hit = np.where(pick == 0, -1, (pick - 1) % max(n, 1))
            hit = np.where(np.isinf(best), -2, hit)
            top = pick > n
            depth[:, u], ids[:, u] = best, hit
            img[:, u] = _shade_column_numpy(
                a,
                hc,
                rig.focal_px,
                ox,
                oy,
                centre,
                dx,
                dy,
                slope,
                best,
                hit,
                top,
                nxs,
                nys,
                sky_cols[0, u],
                sky_rows,
            )
        images.append(img)
        if depth0 is None:
            depth0, ids0 = depth, ids
    assert depth0 is not None and ids0 is not None
    return RenderedPair(images[0], images[1], depth0.astype(np.float32), ids0.astype(np.int16))


def render_bands_reference(
    scene: Scene, rig: StereoRig, bands: list[tuple[Pose2D, int, int]]
) -> RenderedPair:
    """Plain-numpy reference of :meth:`Renderer.render_bands`: each band's rows rendered
    from its pose, stacked."""
    parts = [render_reference(scene, rig, pose, (first, stop)) for pose, first, stop in bands]
    return RenderedPair(
        *(np.concatenate([getattr(p, k) for p in parts]) for k in ("left", "right", "depth", "ids"))
    )


def _shade_column_numpy(
    a, hc, f, ox, oy, centre, dx, dy, slope, best, hit, top, nxs, nys, sky_col, sky_rows
) -> np.ndarray:
    fp = a.fp
    k = np.maximum(hit, 0)
    obstacle = hit >= 0
    flat = ~obstacle | top
    finite = np.where(np.isinf(best), 0.0, best)
    px, py = ox + finite * dx, oy + finite * dy
    nx = np.where(flat, 0.0, nxs[k]) if len(fp) else np.zeros_like(px)
    ny = np.where(flat, 0.0, nys[k]) if len(fp) else np.zeros_like(px)
    nz = np.where(flat, 1.0, 0.0)
    if len(fp):
        along = np.where(fp.kind[k] == DISC, fp.hx[k] * np.arctan2(ny, nx), -ny * px + nx * py)
    else:
        along = px
    sky = hit == -2
    s = np.where(flat, px, along)
    t = np.where(flat, py, hc - slope * finite)
    seed = np.where(obstacle, 2 + 2 * k + top, 0)
    feat = np.where(obstacle, fp.feature_size[k], a.ground_feature) if len(fp) else a.ground_feature
    contrast = (
        np.where(obstacle, fp.contrast[k], a.ground_contrast) if len(fp) else a.ground_contrast
    )
    grazing = np.maximum(slope / np.sqrt(1.0 + slope * slope), _MIN_INCIDENCE_COS)
    ex, ey = px - centre[0], py - centre[1]
    with np.errstate(divide="ignore", invalid="ignore"):
        facing = np.abs(nx * ex + ny * ey) / np.sqrt(ex * ex + ey * ey)
    incidence = np.where(nz > 0.0, grazing, np.maximum(np.nan_to_num(facing), _MIN_INCIDENCE_COS))
    footprint = np.where(sky, 1.0, finite / f / incidence)
    tex = texture_value_numpy(s, t, seed, feat, footprint)
    lambert = np.maximum(nx * a.light[0] + ny * a.light[1] + nz * a.light[2], 0.0)
    gain = (1.0 + contrast * (2.0 * tex - 1.0)) * (a.ambient + (1.0 - a.ambient) * lambert)
    base = np.where(obstacle[:, None], fp.color[k] if len(fp) else 0.0, a.ground_color)
    val = np.clip(base * gain[:, None], 0.0, 1.0)
    sky_tex = 0.5 + 2.0 * (sky_col - 0.5) * (sky_rows - 0.5)
    sky_val = np.clip(a.sky[:3] * (1.0 + a.sky[4] * (2.0 * sky_tex - 1.0))[:, None], 0.0, 1.0)
    val = np.where(sky[:, None], sky_val, val)
    return np.floor(val * 255.0 + 0.5).astype(np.uint8)
