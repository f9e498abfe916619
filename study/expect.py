"""Expected final position error sd from heading-increment noise, odometry alone vs fused with a visual
yaw measurement, holding each recorded trajectory fixed. Noise model = simulator defaults."""
import sys, math, numpy as np
from pathlib import Path
from flylog.experiments.runs import trajectories
F = 250.0; FR = 15.0; DT = 0.02
def sd_w(w): return math.radians(0.5) + 0.05 * abs(w)
for p in sys.argv[1:]:
    t, true, odom = trajectories(Path(p))
    th = np.unwrap(odom[:, 2])
    # frames
    tf = np.arange(t[0], t[-1], 1 / FR)
    x = np.interp(tf, t, odom[:, 0]); y = np.interp(tf, t, odom[:, 1]); h = np.interp(tf, t, th)
    dxy = np.hypot(np.diff(x), np.diff(y)); dth = np.diff(h)
    w = dth * FR; moving = (dxy > 1e-5) | (np.abs(dth) > 1e-5)
    var_o = np.where(moving, np.array([sd_w(v) ** 2 for v in w]) * DT / FR * 1 / DT * DT, 0.0)  # per frame: n steps * (sd*DT)^2
    var_o = np.where(moving, np.array([sd_w(v) ** 2 for v in w]) * (1 / FR / DT) * DT * DT, 0.0)
    kind = np.where(dxy < 1e-4, 0, np.where(np.abs(dth) >= 5e-3, 1, 2))  # 0 turn in place, 1 drive+turn, 2 straight
    sv = {0: 0.10, 1: 0.143, 2: 0.111}
    var_v = np.array([(sv[k] / F) ** 2 for k in kind])
    fused_all = var_o * var_v / (var_o + var_v)
    fused_turn = np.where(kind == 0, fused_all, var_o)
    end = np.array([x[-1], y[-1]]); r = np.hypot(end[0] - x[1:], end[1] - y[1:])
    res = [math.sqrt((v * r * r).sum()) for v in (var_o, fused_turn, fused_all)]
    actual = math.hypot(*(true[-1, :2] - odom[-1, :2]))
    print(f"{Path(p).parent.parent.name}/{Path(p).stem}: actual drift {actual:.2f}  expected heading-driven sd: odom {res[0]:.3f}  fused in-place {res[1]:.3f}  fused all {res[2]:.3f}  "
          f"turn-in-place frames {np.sum(kind==0 & moving)}")
