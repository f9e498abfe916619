"""Sub-pixel (bilinear) variant of the yaw scan, numpy, for the study."""
import numpy as np
from flylog.fly.heading import moved_and_turned

def bilinear_patches(img, u, v, h):
    off = np.arange(-h, h + 1)
    uu = u[:, None, None] + off[None, None, :]
    vv = v[:, None, None] + off[None, :, None]
    x0 = np.floor(uu).astype(np.intp); y0 = np.floor(vv).astype(np.intp)
    fx = (uu - x0)[..., None]; fy = (vv - y0)[..., None]
    I = img.astype(np.float64)
    if I.ndim == 2: I = I[:, :, None]
    a = I[y0, x0]; b = I[y0, x0 + 1]; c = I[y0 + 1, x0]; d = I[y0 + 1, x0 + 1]
    return (a * (1 - fx) + b * fx) * (1 - fy) + (c * (1 - fx) + d * fx) * fy

def inside(rig, uL, uR, v, depth, m):
    ok = (depth > 0) & (v >= m) & (v <= rig.height - 2 - m)
    for u in (uL, uR): ok &= (u >= m) & (u <= rig.width - 2 - m)
    return ok

def measure_subpixel(before, after, xyz, inc, rig, cfg):
    offsets = cfg.offsets(rig.focal_px); h = cfg.window // 2; n = cfg.window ** 2
    uL, uR, v, dep = rig.project(xyz)
    ok = inside(rig, uL, uR, v, dep, h + 1)
    for e in (offsets[0], offsets[-1]):
        a = rig.project(moved_and_turned(xyz, inc, float(e))); ok &= inside(rig, *a, h + 1)
    idx = np.flatnonzero(ok)[: cfg.flies]
    if len(idx) < cfg.min_flies: return None, len(idx)
    X = xyz[idx]; uL, uR, v = uL[idx], uR[idx], v[idx]
    C = 3 if before[0].ndim == 3 else 1
    g = cfg.guard * n * C
    AL = bilinear_patches(before[0], uL, v, h); AR = bilinear_patches(before[1], uR, v, h)
    gx = AL[:, h, h + 1] - AL[:, h, h - 1]
    wgt = np.sqrt(np.sqrt((gx ** 2).sum(axis=-1)))
    scores = []
    for e in offsets:
        pL, pR, pv, _ = rig.project(moved_and_turned(X, inc, float(e)))
        tot = 0
        for A, img, pu in ((AL, after[0], pL), (AR, after[1], pR)):
            B = bilinear_patches(img, pu, pv, h)
            d = A - B; s1 = d.sum(axis=(1, 2)); s2 = (d * d).sum(axis=(1, 2))
            z = (n * s2 - s1 * s1).sum(axis=1) / n
            tot = tot + 1.0 / (z + g)
        scores.append(float((wgt * tot).sum()))
    from flylog.fly.heading import scan_peak
    return scan_peak(offsets, np.array(scores)), len(idx)
