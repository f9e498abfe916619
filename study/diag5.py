"""diag2.py SCENE SEED TAG: odometry-only closed loop (heading gate 0), heading measured with fly-subset variants."""
import sys, pickle
from pathlib import Path
import numpy as np
sys.meta_path[:] = [f for f in sys.meta_path if "editable" not in repr(f)]
sys.path.insert(0, "/work/wt-heading")
import flylog
import flylog.replay.pipeline as P
assert "wt-heading" in P.__file__, P.__file__
sys.path.insert(0, "/tmp/lead7")
from refine import refined_points
from ground import ground_points
from subpix import measure_subpixel
scene, seed, tag = sys.argv[1], int(sys.argv[2]), sys.argv[3]
rec = []
orig = P.measure_yaw
def spy(before, after, xyz, inc, rig, cfg, **k):
    depth = xyz[:, 0] - rig.mount_x
    out = {"t": None, "inc": (inc.x, inc.y, inc.theta)}
    for name, sel in (("all", slice(None)), ("d6", depth < 6)):
        m = orig(before, after, xyz[sel], inc, rig, cfg)
        out[name] = m.yaw
    out["sub"] = measure_subpixel(before, after, xyz, inc, rig, cfg)[0]
    m = orig(before, after, xyz, inc, rig, cfg)
    rec.append(out)
    return m
P.measure_yaw = spy
orig_h = P.FlyPipeline._heading_measured
def spy_h(self, pair, odometry, pose):
    n = len(rec); r = orig_h(self, pair, odometry, pose)
    if len(rec) > n: rec[-1]["t"] = pair.stamp_ns
    return r
P.FlyPipeline._heading_measured = spy_h
from flylog.experiments.common import ExperimentOptions
from flylog.experiments import closed_loop as cl
here = Path(f"/tmp/lead7/runs/{tag}"); (here / "runs").mkdir(parents=True, exist_ok=True)
opts = ExperimentOptions(seeds=1, keep_logs=True, resolution=(320, 240))
row, drawn = cl._one_run(here, opts, {"heading.gate": 0.0}, scene, seed)
print({k: row[k] for k in ("success", "final_goal_distance_m", "final_drift_m", "path_length_m")})
pickle.dump(rec, open(here / f"{scene}_s{seed}.pkl", "wb"))
