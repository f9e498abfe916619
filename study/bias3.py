import dataclasses, sys, numpy as np
sys.path.insert(0, "/tmp/lead7")
from refine import refined_points
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
res = {k: [] for k in ("x1.1", "x1.1 refined", "x1.0 refined")}
for h in np.linspace(0, 2*np.pi, 16, endpoint=False):
    A = compose(scene.start_pose, Pose2D(0, 0, h))
    fa = r.render(A)
    u, v = rng.uniform(4, 316, 8000), rng.uniform(4, 236, 8000)
    d = fa.depth[np.round(v).astype(int), np.round(u).astype(int)].astype(float); ok = np.isfinite(d)
    sets = {"x1.1": rig.backproject(u[ok], v[ok], d[ok] * 1.1)}
    sets["x1.1 refined"] = refined_points(fa.left, fa.right, sets["x1.1"], rig)[0]
    sets["x1.0 refined"] = refined_points(fa.left, fa.right, rig.backproject(u[ok], v[ok], d[ok]), rig)[0]
    for dth in (TURN, -TURN):
        eps = rng.normal(0, 0.3) / 250
        fb = r.render(compose(A, Pose2D(0, 0, dth + eps)))
        for k, xyz in sets.items():
            m = measure_yaw((fa.left, fa.right), (fb.left, fb.right), xyz, Pose2D(0, 0, dth), rig, cfg)
            if m.yaw is not None: res[k].append((h, dth, (m.yaw - eps) * 250))
for s, rows in res.items():
    a = np.array(rows)
    pos, neg = a[a[:,1] > 0, 2], a[a[:,1] < 0, 2]
    print(f"{name} {s}: n={len(a)} error mean {a[:,2].mean():+.4f} sd {a[:,2].std():.3f}; +turn mean {pos.mean():+.4f} -turn mean {neg.mean():+.4f}")
