import numpy as np
def ground_points(xyz, rig, max_height=0.1, min_rows_below=8):
    """The flies within max_height of the ground, replaced by the ground point under their left pixel centre
    (depth from the flat ground and the camera height, not from stereo)."""
    uL, uR, v, depth = rig.project(xyz)
    c = np.floor(uL + 0.5); r = np.floor(v + 0.5)
    sel = (np.abs(xyz[:, 2]) < max_height) & (depth > 0) & (r - rig.cy > min_rows_below)
    c, r = c[sel], r[sel]
    z = rig.focal_px * rig.mount_height / (r - rig.cy)  # depth along the optical axis to the ground
    return rig.backproject(c, r, z), np.flatnonzero(sel)
