import dataclasses, numpy as np
from pathlib import Path
from flylog.scene.load import load_scene
from flylog.sim.render import Renderer
from flylog.geometry import Pose2D, compose
from flylog.fly.heading import HeadingConfig, measure_yaw
scene = load_scene(Path("/work/main/fixtures/scenes/corridor.toml"))
rig = dataclasses.replace(scene.spec.camera, width=320, height=240, focal_px=250.0)
r = Renderer(scene, rig); cfg = HeadingConfig(); rng = np.random.default_rng(0)
TURN = 0.5/15
for start_turn in (0.0, 1.0, 2.5):
    A = compose(scene.start_pose, Pose2D(0, 0, start_turn))
    fa = r.render(A)
    u, v = rng.uniform(4, 316, 6000), rng.uniform(4, 236, 6000)
    d = fa.depth[np.round(v).astype(int), np.round(u).astype(int)].astype(float); ok = np.isfinite(d)
    for scale in (1.0, 1.2, 0.85):
        xyz = rig.backproject(u[ok], v[ok], d[ok] * scale)
        res = []
        for dth in (TURN, -TURN):
            fb = r.render(compose(A, Pose2D(0, 0, dth)))
            m = measure_yaw((fa.left, fa.right), (fb.left, fb.right), xyz, Pose2D(0, 0, dth), rig, cfg)
            res.append(m.yaw * 250)
        print(f"heading {start_turn} depth x{scale}: measured error px at +turn {res[0]:+.3f}, -turn {res[1]:+.3f}")
