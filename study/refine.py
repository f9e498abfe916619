import numpy as np
from flylog.fly.fitness import as_planes
def refined_points(left, right, xyz, rig, window=7, guard=1.0, reach=2):
    """Pixel-centre points at a stereo-refined depth: the flies' left pixels, their disparity re-found by an
    integer scan of ±reach px around the fly's and a parabola."""
    L, R = as_planes(left), as_planes(right)
    H, W, C = L.shape; h = window // 2; n = window * window
    uL, uR, v, depth = rig.project(xyz)
    c = np.floor(uL + 0.5).astype(int); r = np.floor(v + 0.5).astype(int)
    d0 = np.floor(uL - uR + 0.5).astype(int)
    ds = np.arange(-reach - 1, reach + 2)
    ok = (depth > 0) & (r >= h) & (r < H - h) & (c >= h) & (c < W - h) & (c - d0 - ds[-1] >= h) & (c - d0 - ds[0] < W - h)
    idx = np.flatnonzero(ok); c, r, d0 = c[idx], r[idx], d0[idx]
    off = np.arange(-h, h + 1)
    rr = r[:, None, None] + off[None, :, None]
    pl = L[rr, c[:, None, None] + off[None, None, :]].astype(np.int64)
    scores = []
    for dd in ds:
        cr = c - d0 - dd
        pr = R[rr, cr[:, None, None] + off[None, None, :]].astype(np.int64)
        dlt = pl - pr; s1 = dlt.sum(axis=(1, 2)); s2 = (dlt * dlt).sum(axis=(1, 2))
        scores.append(1.0 / ((n * s2 - s1 * s1).sum(axis=1) / n + guard * n * C))
    S = np.array(scores)  # (nd, M)
    i = np.argmax(S[1:-1], axis=0) + 1
    y0, y1, y2 = S[i - 1, np.arange(len(i))], S[i, np.arange(len(i))], S[i + 1, np.arange(len(i))]
    den = y0 - 2 * y1 + y2
    shift = np.where(den < 0, 0.5 * (y0 - y2) / np.where(den < 0, den, -1), 0.0)
    disp = d0 + ds[i] + shift
    good = disp > 0.5
    z = rig.focal_px * rig.baseline / disp[good]
    return rig.backproject(c[good].astype(float), r[good].astype(float), z), idx[good]
