import dataclasses, sys, numpy as np
from pathlib import Path
from flylog.scene.load import load_scene
from flylog.sim.render import Renderer
from flylog.geometry import Pose2D, compose
from flylog.fly.heading import HeadingConfig, measure_yaw
name = sys.argv[1] if len(sys.argv) > 1 else "corridor"
scene = load_scene(Path(f"/work/main/fixtures/scenes/{name}.toml"))
rig = dataclasses.replace(scene.spec.camera, width=320, height=240, focal_px=250.0)
r = Renderer(scene, rig); cfg = HeadingConfig(); rng = np.random.default_rng(0)
TURN = 0.5/15
res = {s: [] for s in (1.0, 1.1)}
for h in np.linspace(0, 2*np.pi, 16, endpoint=False):
    A = compose(scene.start_pose, Pose2D(0, 0, h))
    fa = r.render(A)
    u, v = rng.uniform(4, 316, 8000), rng.uniform(4, 236, 8000)
    d = fa.depth[np.round(v).astype(int), np.round(u).astype(int)].astype(float); ok = np.isfinite(d)
    for scale in res:
        xyz = rig.backproject(u[ok], v[ok], d[ok] * scale)
        for dth in (TURN, -TURN):
            eps = rng.normal(0, 0.3) / 250
            fb = r.render(compose(A, Pose2D(0, 0, dth + eps)))
            m = measure_yaw((fa.left, fa.right), (fb.left, fb.right), xyz, Pose2D(0, 0, dth), rig, cfg)
            if m.yaw is not None: res[scale].append((h, dth, (m.yaw - eps) * 250))
for s, rows in res.items():
    a = np.array(rows)
    pos, neg = a[a[:,1] > 0, 2], a[a[:,1] < 0, 2]
    print(f"{name} depth x{s}: n={len(a)} error mean {a[:,2].mean():+.4f} sd {a[:,2].std():.3f}; +turn mean {pos.mean():+.4f} -turn mean {neg.mean():+.4f}")
