import dataclasses, numpy as np
from pathlib import Path
from flylog.io import open_log, contract
from flylog.metrics.truth import read_truth
from flylog.scene.load import load_scene
from flylog.sim.render import Renderer
from flylog.geometry import Pose2D
log = Path("/tmp/lead7/runs/d4/runs/clutter_s0.mcap")
tr = read_truth(log)
scene = load_scene(Path("/work/main/fixtures/scenes/clutter.toml"))
rig = tr.rig
r = Renderer(scene, rig)
tT = np.asarray(tr.true.t_ns); X = np.asarray(tr.true.xyt).copy(); X[:, 2] = np.unwrap(X[:, 2])
n = 0
for m in open_log(log).messages([contract.LEFT_IMAGE]):
    t = m.log_time_ns
    if t < 3e9: continue
    p = Pose2D(*(float(np.interp(t, tT, X[:, i])) for i in range(3)))
    best = None
    for dth in np.arange(-0.6, 0.61, 0.1) / 250:
        img = r.render(Pose2D(p.x, p.y, p.theta + dth)).left.astype(int)
        diff = np.abs(img - m.value.astype(int)).mean()
        if best is None or diff < best[0]: best = (diff, dth * 250)
    print(f"t={t/1e9:.3f} best extra yaw {best[1]:+.1f} px (mean abs diff {best[0]:.3f})")
    n += 1
    if n >= 8: break
