"""The stereo renderer: textured, Lambert-shaded obstacles on a textured ground, by ray casting.

Every obstacle is a vertical extrusion and both cameras are horizontal, so an image column is
a single 2-D ray in the ground plane: it is intersected once with every footprint (entry and
exit depths, sorted), then each pixel of the column walks those hits and tests the height of
its 3-D ray at them (a side face if the height at entry is within [0, h], the top face if the
ray comes down through h inside the footprint), else the ground (ray going down) or the sky.
The 2-D ray parameter is the depth along the optical axis, so depth comes for free.

:class:`Renderer` runs a numba kernel, parallel over blocks of columns of both images, over a
range of rows (a rolling shutter's band, or the whole frame); each column first finds its
surfaces, then textures the range's rows at once (vectorised, see
:func:`flylog.sim.textures.texture_column`), then shades them;
:func:`tests.sim.render_reference.render_reference` is the plain-numpy reference (slow, for
tests at small sizes).
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass

import numba
import numpy as np

from flylog.geometry import Pose2D, StereoRig
from flylog.scene.footprints import DISC, Footprints
from flylog.scene.load import Scene
from flylog.scene.ray_kernel import ray_hit
from flylog.sim.rotated import Warp, sample_colour, sample_truth, warps
from flylog.sim.textures import texture_column, value_noise_1d_numpy

GROUND = -1
SKY = -2
# Columns per parallel job (their scratch arrays are allocated once per job).
_BLOCK = 16
# A pixel's footprint on a surface grows as 1/cos(incidence), capped for grazing views; the
# texture's octaves finer than the footprint fade to their mean, as a real lens and sensor
# would average them. The incidence must be the same in both cameras, so that the fading,
# and hence the colour of a surface point, is the same in both images: on the ground (and
# tops) it is taken from the image row only; on a vertical face, from the horizontal
# direction of the point seen from the cyclopean centre (midway between the cameras).
# Without it a wall seen at a grazing angle aliases its fine octaves into noise that differs
# between the two images, and no stereo method can match it.
# Texture seeds: 0 ground, 1 and 2 sky (azimuth, elevation), 2 + 2k (+1 top) obstacle k.
SKY_SEED = 1
_MIN_INCIDENCE_COS = 0.05


@dataclass(frozen=True, slots=True)
class RenderedPair:
    """A rendered stereo pair and the left camera's ground truth."""

    left: np.ndarray  # (H, W, 3) uint8 RGB
    right: np.ndarray  # (H, W, 3) uint8 RGB
    depth: np.ndarray  # (H, W) float32, m along the left optical axis; inf = sky
    ids: np.ndarray  # (H, W) int16: obstacle index, GROUND (-1) or SKY (-2)


@dataclass(frozen=True)
class _SceneArrays:
    """Everything the kernel needs about the scene, as flat arrays and numbers."""

    fp: Footprints
    ground_color: np.ndarray  # (3,)
    ground_feature: float
    ground_contrast: float
    light: np.ndarray  # (3,) unit vector towards the light
    ambient: float
    sky: np.ndarray  # (5,): RGB, texture feature size (rad), texture contrast


def _scene_arrays(scene: Scene) -> _SceneArrays:
    tex = scene.spec.ground.texture
    lighting = scene.spec.lighting
    return _SceneArrays(
        fp=scene.footprints,
        ground_color=np.array(tex.color, dtype=float),
        ground_feature=tex.feature_size,
        ground_contrast=tex.contrast,
        light=np.array(lighting.light_vector()),
        ambient=lighting.ambient,
        sky=np.array(
            [*lighting.sky_color, math.radians(lighting.sky_feature_deg), lighting.sky_contrast]
        ),
    )


def _camera_rays(rig: StereoRig, pose: Pose2D, side: str) -> tuple[float, float, np.ndarray]:
    """World origin (x, y) of a camera and the (W, 2) world 2-D ray direction of each column,
    scaled so that the ray parameter is the depth."""
    mx, my, _ = rig.camera_position(side)
    c, s = math.cos(pose.theta), math.sin(pose.theta)
    ox, oy = pose.x + c * mx - s * my, pose.y + s * mx + c * my
    cx = rig.cx if side == "left" else rig.cx_right
    lateral = -(np.arange(rig.width) - cx) / rig.focal_px  # base_link y per metre of depth
    return ox, oy, np.stack([c - s * lateral, s + c * lateral], axis=1)


def _cyclopean_centre(rig: StereoRig, pose: Pose2D) -> np.ndarray:
    """World (x, y) of the point midway between the two optical centres."""
    mx, my = rig.mount_x, rig.mount_y
    c, s = math.cos(pose.theta), math.sin(pose.theta)
    return np.array([pose.x + (c * mx - s * my), pose.y + (s * mx + c * my)])


def sky_pattern(rig: StereoRig, dirs: np.ndarray, feature: float) -> tuple[np.ndarray, np.ndarray]:
    """The sky's 1-D patterns: (cams, W) along the azimuth of each column's world direction
    ``dirs`` (cams, W, 2), and (H,) along the elevation of each row; in [0, 1). Rectified
    cameras have parallel rays in the same column, so both see the same sky: zero disparity.
    """
    azimuth = np.arctan2(dirs[..., 1], dirs[..., 0])
    elevation = np.arctan(-(np.arange(rig.height) - rig.cy) / rig.focal_px)
    return (
        value_noise_1d_numpy(azimuth / feature, SKY_SEED),
        value_noise_1d_numpy(elevation / feature, SKY_SEED + 1),
    )


# One band of a frame: rows [first, stop) rendered from ``pose``.
Band = tuple[Pose2D, int, int]


class Renderer:
    """Renders a scene from the robot's true pose; the scene is compiled once. A rig that is
    not level is drawn through level cameras (:mod:`flylog.sim.rotated`). A frame may be
    rendered in bands of rows, each from its own pose (a rolling shutter): a row's pixels
    depend on its own pose only, so a frame of one band is the frame of that pose."""

    def __init__(self, scene: Scene, rig: StereoRig) -> None:
        self.scene = scene
        self.rig = rig
        self._arrays = _scene_arrays(scene)
        self._warps = None if rig.is_level else warps(rig)

    def _run(
        self,
        bands: Sequence[Band],
        rig: StereoRig,
        sides: tuple[str, ...],
        out: tuple[np.ndarray, np.ndarray, np.ndarray],
    ) -> None:
        """The bands' rows of level cameras ``sides`` of ``rig``, each from its band's pose,
        into ``out``: (cams, H, W, 3) images (cams 0 without colour), the first camera's (H,
        W) depth and ids. One kernel call renders every band: a call's fixed cost (starting
        the threads) is paid once a frame."""
        a, fp = self._arrays, self._arrays.fp
        rgb, depth, ids = out
        want_color = rgb.shape[0] > 0
        n = len(bands)
        origins = np.zeros((n, len(sides), 2))
        dirs = np.zeros((n, len(sides), rig.width, 2))
        centre = np.zeros((n, 2))
        rows = np.array([(first, stop) for _, first, stop in bands], dtype=np.int64)
        for b, (pose, _, _) in enumerate(bands):
            centre[b] = _cyclopean_centre(self.rig, pose)
            for i, side in enumerate(sides):
                ox, oy, d = _camera_rays(rig, pose, side)
                origins[b, i] = ox, oy
                dirs[b, i] = d
        if want_color:
            sky_cols, sky_rows = sky_pattern(rig, dirs.reshape(-1, rig.width, 2), a.sky[3])
            sky_cols = sky_cols.reshape(dirs.shape[:3])
        else:  # depth and ids do not depend on the sky's colour (metrics render 300 views)
            sky_cols, sky_rows = np.zeros(dirs.shape[:3]), np.zeros(rig.height)
        # Blocks handed out one at a time: a thread slowed by other processes on its core
        # does fewer of them instead of holding up the frame.
        with numba.parallel_chunksize(1):
            _render_kernel(
                # the cameras and their rays
                origins,
                centre,
                dirs,
                rig.mount_height,
                rig.focal_px,
                rig.cy,
                rig.height,
                # the bands' rows, [first, stop) each
                rows,
                # footprints, one entry per obstacle
                fp.kind,
                fp.cx,
                fp.cy,
                fp.cos,
                fp.sin,
                fp.hx,
                fp.hy,
                fp.height,
                fp.color,
                fp.feature_size,
                fp.contrast,
                # ground, light and sky
                a.ground_color,
                a.ground_feature,
                a.ground_contrast,
                a.light,
                a.ambient,
                a.sky,
                sky_cols,
                sky_rows,
                # whether to draw the images, and the outputs
                want_color,
                rgb,
                depth,
                ids,
            )

    def _frame(
        self, bands: Sequence[Band], want_color: bool
    ) -> tuple[list[np.ndarray], np.ndarray, np.ndarray]:
        """The (left, right) images (none without ``want_color``) and the left camera's
        depth and ids of a frame whose bands of rows are rendered each from its pose."""
        rig = self.rig
        depth = np.empty((rig.height, rig.width), dtype=np.float32)
        ids = np.empty((rig.height, rig.width), dtype=np.int16)
        if self._warps is None:
            rgb = np.empty((2 if want_color else 0, rig.height, rig.width, 3), dtype=np.uint8)
            sides = ("left", "right") if want_color else ("left",)
            self._run(bands, rig, sides, (rgb, depth, ids))
            return list(rgb), depth, ids
        images = []
        for c, warp in enumerate(self._warps if want_color else self._warps[:1]):
            level = warp.level
            level_rgb = np.empty(
                (1 if want_color else 0, level.height, level.width, 3), dtype=np.uint8
            )
            level_depth = np.empty((level.height, level.width), dtype=np.float32)
            level_ids = np.empty((level.height, level.width), dtype=np.int16)
            image = np.empty((rig.height, rig.width, 3), dtype=np.uint8)
            for pose, first, stop in bands:
                part = Warp(level, warp.u[first:stop], warp.v[first:stop], warp.scale[first:stop])
                # the level rows the band's pixels sample (bilinear reads reach one row down);
                # the bands' level rows overlap, so each band is a kernel call of its own
                lo = int(np.floor(part.v.min()))
                hi = int(np.floor(part.v.max())) + 2
                self._run([(pose, lo, hi)], level, ("left",), (level_rgb, level_depth, level_ids))
                if want_color:
                    image[first:stop] = sample_colour(level_rgb[0], part)
                if c == 0:
                    depth[first:stop], ids[first:stop] = sample_truth(level_depth, level_ids, part)
            images.append(image)
        return images if want_color else [], depth, ids

    def render(self, pose: Pose2D) -> RenderedPair:
        """Both images and the left camera's depth and ids, from the true robot pose."""
        return self.render_bands([(pose, 0, self.rig.height)])

    def render_bands(self, bands: Sequence[Band]) -> RenderedPair:
        """Both images and the left camera's depth and ids of a frame whose rows
        [first, stop) of each band are seen from the band's pose (the bands cover the
        image's rows once)."""
        (left, right), depth, ids = self._frame(bands, want_color=True)
        return RenderedPair(left=left, right=right, depth=depth, ids=ids)

    def render_depth(self, pose: Pose2D) -> tuple[np.ndarray, np.ndarray]:
        """The left camera's (depth, ids) only: ground truth for the metrics."""
        _, depth, ids = self._frame([(pose, 0, self.rig.height)], want_color=False)
        return depth, ids


# No nnan/ninf fast-math: depth uses inf for the sky.
@numba.njit(cache=True, parallel=True, fastmath={"nsz", "arcp", "contract", "afn"})
def _render_kernel(
    # the cameras and their rays
    origins,
    centre,
    dirs,
    hc,
    f,
    cy,
    height,
    # the bands' rows, [first, stop) each
    rows,
    # footprints, one entry per obstacle
    kind,
    ocx,
    ocy,
    ocos,
    osin,
    ohx,
    ohy,
    oh,
    ocolor,
    ofeat,
    ocontrast,
    # ground, light and sky
    gcolor,
    gfeat,
    gcontrast,
    light,
    ambient,
    sky,
    sky_cols,
    sky_rows,
    # whether to draw the images, and the outputs
    want_color,
    rgb,
    depth,
    ids,
):
    # Band b: rows rows[b, 0]..rows[b, 1] - 1 seen from origins[b], centre[b], dirs[b].
    n_bands, n_cams, width = dirs.shape[0], dirs.shape[1], dirs.shape[2]
    n = kind.shape[0]
    n_blocks = (width + _BLOCK - 1) // _BLOCK
    for job in numba.prange(n_cams * n_blocks):
        cam, block = job // n_blocks, job % n_blocks
        # Scratch for a block of columns: per obstacle (hits), per row (surface, texture).
        t_in = np.empty(n)
        t_out = np.empty(n)
        nxs = np.empty(n)
        nys = np.empty(n)
        side_s = np.empty(n)
        order = np.empty(n, dtype=np.int64)
        r_best = np.empty(height)
        r_hit = np.empty(height, dtype=np.int64)
        r_top = np.empty(height, dtype=np.bool_)
        r_s = np.empty(height)
        r_t = np.empty(height)
        r_seed = np.empty(height, dtype=np.int64)
        r_feat = np.empty(height)
        r_fp = np.empty(height)
        r_tex = np.empty(height)
        r_q = np.empty((3, height))
        for u in range(block * _BLOCK, min(block * _BLOCK + _BLOCK, width)):
            for b in range(n_bands):
                _render_column(
                    # the column drawn: its camera and image column
                    cam,
                    u,
                    # the cameras and their rays
                    origins[b],
                    centre[b],
                    dirs[b],
                    hc,
                    f,
                    cy,
                    height,
                    # the rows drawn, [v0, v1)
                    rows[b, 0],
                    rows[b, 1],
                    # footprints, one entry per obstacle
                    kind,
                    ocx,
                    ocy,
                    ocos,
                    osin,
                    ohx,
                    ohy,
                    oh,
                    ocolor,
                    ofeat,
                    ocontrast,
                    # ground, light and sky
                    gcolor,
                    gfeat,
                    gcontrast,
                    light,
                    ambient,
                    sky,
                    sky_cols[b],
                    sky_rows,
                    # whether to draw the images, and the outputs
                    want_color,
                    rgb,
                    depth,
                    ids,
                    # scratch per obstacle
                    t_in,
                    t_out,
                    nxs,
                    nys,
                    side_s,
                    order,
                    # scratch per row
                    r_best,
                    r_hit,
                    r_top,
                    r_s,
                    r_t,
                    r_seed,
                    r_feat,
                    r_fp,
                    r_tex,
                    r_q,
                )


@numba.njit(cache=True, fastmath={"nsz", "arcp", "contract", "afn"})
def _render_column(
    # the column drawn: its camera and image column
    cam,
    u,
    # the cameras and their rays
    origins,
    centre,
    dirs,
    hc,
    f,
    cy,
    height,
    # the rows drawn, [v0, v1)
    v0,
    v1,
    # footprints, one entry per obstacle
    kind,
    ocx,
    ocy,
    ocos,
    osin,
    ohx,
    ohy,
    oh,
    ocolor,
    ofeat,
    ocontrast,
    # ground, light and sky
    gcolor,
    gfeat,
    gcontrast,
    light,
    ambient,
    sky,
    sky_cols,
    sky_rows,
    # whether to draw the images, and the outputs
    want_color,
    rgb,
    depth,
    ids,
    # scratch per obstacle
    t_in,
    t_out,
    nxs,
    nys,
    side_s,
    order,
    # scratch per row
    r_best,
    r_hit,
    r_top,
    r_s,
    r_t,
    r_seed,
    r_feat,
    r_fp,
    r_tex,
    r_q,
):
    n = kind.shape[0]
    ox, oy = origins[cam, 0], origins[cam, 1]
    dx, dy = dirs[cam, u, 0], dirs[cam, u, 1]
    n_hit = 0
    for k in range(n):
        a, b, nx, ny = ray_hit(
            kind[k], ocx[k], ocy[k], ocos[k], osin[k], ohx[k], ohy[k], ox, oy, dx, dy
        )
        t_in[k], t_out[k], nxs[k], nys[k] = a, b, nx, ny
        if b >= a:
            # A side face is hit at the same 2-D point by every row: its texture
            # coordinate along the face is computed once per column.
            ex, ey = ox + a * dx, oy + a * dy
            if kind[k] == DISC:
                side_s[k] = ohx[k] * math.atan2(ny, nx)
            else:
                side_s[k] = -ny * ex + nx * ey
            # Insertion sort by entry depth: a column crosses few footprints.
            j = n_hit
            while j > 0 and t_in[order[j - 1]] > a:
                order[j] = order[j - 1]
                j -= 1
            order[j] = k
            n_hit += 1
    first_seen = v1  # sky is the top of a column: the rows above the first surface
    for v in range(v0, v1):
        slope = (v - cy) / f  # the 3-D ray descends by `slope` per metre of depth
        best, hit, top = np.inf, -2, False
        if slope > 0.0:
            best, hit = hc / slope, -1
        for i in range(n_hit):
            k = order[i]
            if t_in[k] >= best:
                break
            if t_in[k] > 0.0:
                z_in = hc - slope * t_in[k]
                if 0.0 <= z_in <= oh[k]:
                    best, hit, top = t_in[k], k, False
                    continue
            if slope > 0.0 and hc > oh[k]:
                t_top = (hc - oh[k]) / slope
                if max(t_in[k], 0.0) <= t_top <= t_out[k] and t_top < best:
                    best, hit, top = t_top, k, True
        if cam == 0:
            depth[v, u] = best
            ids[v, u] = hit
        if not want_color:
            continue
        r_best[v], r_hit[v], r_top[v] = best, hit, top
        if hit == -2:
            r_s[v], r_t[v], r_seed[v], r_feat[v], r_fp[v] = 0.0, 0.0, 0, 1.0, 1.0
            continue
        first_seen = min(first_seen, v)
        px, py = ox + best * dx, oy + best * dy
        if hit == -1 or top:
            s, t = px, py
        else:
            s, t = side_s[hit], hc - slope * best
        if hit == -1:
            seed, feat = 0, gfeat
        else:
            seed = 2 + 2 * hit + (1 if top else 0)
            feat = ofeat[hit]
        if hit == -1 or top:
            incidence = max(slope / math.sqrt(1.0 + slope * slope), _MIN_INCIDENCE_COS)
        else:
            ex, ey = px - centre[0], py - centre[1]
            facing = abs(nxs[hit] * ex + nys[hit] * ey) / math.sqrt(ex * ex + ey * ey)
            incidence = max(facing, _MIN_INCIDENCE_COS)
        r_s[v], r_t[v], r_seed[v], r_feat[v], r_fp[v] = s, t, seed, feat, best / f / incidence
    if not want_color:
        return
    # The texture of the column's rows at once, in vectorised loops: most of the time. A
    # row's texture depends on that row's values only, not on which rows are rendered.
    texture_column(r_s, r_t, r_seed, r_feat, r_fp, first_seen, v1, r_tex, r_q)
    for v in range(v0, v1):
        hit, top, best = r_hit[v], r_top[v], r_best[v]
        if hit == -2:
            # The sky's pattern depends on the direction only: zero disparity.
            tex = 0.5 + 2.0 * (sky_cols[cam, u] - 0.5) * (sky_rows[v] - 0.5)
            gain = 1.0 + sky[4] * (2.0 * tex - 1.0)
            for ch in range(3):
                val = min(max(sky[ch] * gain, 0.0), 1.0)
                rgb[cam, v, u, ch] = np.uint8(math.floor(val * 255.0 + 0.5))
            continue
        if hit == -1 or top:
            nx, ny, nz = 0.0, 0.0, 1.0
        else:
            nx, ny, nz = nxs[hit], nys[hit], 0.0
        contrast = gcontrast if hit == -1 else ocontrast[hit]
        tex = r_tex[v]
        lambert = max(nx * light[0] + ny * light[1] + nz * light[2], 0.0)
        shade = ambient + (1.0 - ambient) * lambert
        gain = (1.0 + contrast * (2.0 * tex - 1.0)) * shade
        for ch in range(3):
            base = gcolor[ch] if hit == -1 else ocolor[hit, ch]
            val = min(max(base * gain, 0.0), 1.0)
            rgb[cam, v, u, ch] = np.uint8(math.floor(val * 255.0 + 0.5))
