"""diag.py SCENE SEED TAG [overrides-json]: closed-loop run with the heading's per-frame numbers recorded."""
import sys, json, pickle, math
from pathlib import Path
import numpy as np
import flylog.replay.pipeline as P
from flylog.fly import heading as H
scene, seed, tag = sys.argv[1], int(sys.argv[2]), sys.argv[3]
ov = json.loads(sys.argv[4]) if len(sys.argv) > 4 else {}
rec = []
orig_measure = P.measure_yaw
last = {}
def spy_measure(*a, **k):
    m = orig_measure(*a, **k); last["m"] = m; last["inc"] = a[3]; return m
P.measure_yaw = spy_measure
orig = P.FlyPipeline._heading_measured
def spy(self, pair, odometry, pose):
    last.clear()
    out = orig(self, pair, odometry, pose)
    m = last.get("m")
    var = self.config.heading.odometry_variance(last["inc"], 1/15) if "inc" in last else 0
    rec.append(dict(t=pair.stamp_ns, odom=odometry.theta, before=pose.theta, after=out.theta,
                    meas=None if m is None else m.yaw, flies=None if m is None else m.flies, var=var,
                    inc=None if "inc" not in last else (last["inc"].x, last["inc"].y, last["inc"].theta)))
    return out
P.FlyPipeline._heading_measured = spy
from flylog.experiments.common import ExperimentOptions
from flylog.experiments import closed_loop as cl
here = Path(f"/tmp/lead7/runs/{tag}"); (here / "runs").mkdir(parents=True, exist_ok=True)
opts = ExperimentOptions(seeds=1, keep_logs=True, resolution=(320, 240))
row, drawn = cl._one_run(here, opts, ov, scene, seed)
print({k: row[k] for k in ("success", "final_goal_distance_m", "final_drift_m", "path_length_m")})
pickle.dump(rec, open(here / f"{scene}_s{seed}.pkl", "wb"))
