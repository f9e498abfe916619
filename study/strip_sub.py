import dataclasses, sys, numpy as np
from pathlib import Path
from flylog.scene.load import load_scene
from flylog.sim.render import Renderer
from flylog.geometry import Pose2D, compose
from flylog.fly.heading import HeadingConfig, measure_yaw
import sys; sys.path.insert(0, "/tmp/lead7"); from subpix import measure_subpixel
scene = load_scene(Path("/work/main/fixtures/scenes/clutter.toml"))
rig = dataclasses.replace(scene.spec.camera, width=320, height=240, focal_px=250.0)
r = Renderer(scene, rig); cfg = HeadingConfig(min_flies=50); rng = np.random.default_rng(0)
TURN = 0.5/15
for lo, hi, integer in ((4, 316, False), (150, 170, False), (60, 80, False), (150, 170, True), (4, 316, True)):
    res = []
    for h in np.linspace(0, 2*np.pi, 12, endpoint=False):
        A = compose(scene.start_pose, Pose2D(0, 0, h)); fa = r.render(A)
        u, v = rng.uniform(lo, hi, 6000), rng.uniform(4, 236, 6000)
        if integer: u, v = np.round(u), np.round(v)
        d = fa.depth[np.round(v).astype(int), np.round(u).astype(int)].astype(float); ok = np.isfinite(d)
        xyz = rig.backproject(u[ok], v[ok], d[ok])
        for dth in (TURN, -TURN):
            eps = rng.normal(0, 0.3) / 250
            fb = r.render(compose(A, Pose2D(0, 0, dth + eps)))
            y, _ = measure_subpixel((fa.left, fa.right), (fb.left, fb.right), xyz, Pose2D(0, 0, dth), rig, cfg)
            if y is not None: res.append((dth, (y - eps) * 250))
    a = np.array(res)
    print(f"columns {lo}-{hi} integer={integer}: +turn bias {a[a[:,0]>0,1].mean():+.4f} -turn {a[a[:,0]<0,1].mean():+.4f} sd {a[:,1].std():.3f} n={len(a)}")
