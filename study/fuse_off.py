import sys, pickle, math, numpy as np
from pathlib import Path
from flylog.metrics.truth import read_truth
F = 250.0
tag, name, var = sys.argv[1], sys.argv[2], sys.argv[3]
sd_turn, sd_drive = float(sys.argv[4]), float(sys.argv[5])
rec = [r for r in pickle.load(open(f"/tmp/lead7/runs/{tag}/{name}.pkl", "rb")) if r["t"] is not None]
tr = read_truth(Path(f"/tmp/lead7/runs/{tag}/runs/{name}.mcap"))
tT = np.asarray(tr.true.t_ns); X = np.asarray(tr.true.xyt).copy(); X[:, 2] = np.unwrap(X[:, 2])
tO = np.asarray(tr.odom.t_ns); O = np.asarray(tr.odom.xyt).copy(); O[:, 2] = np.unwrap(O[:, 2])
t = np.array([r["t"] for r in rec]); prev = t - round(1e9 / 15)
eps = (np.interp(t, tT, X[:, 2]) - np.interp(prev, tT, X[:, 2])) - (np.interp(t, tO, O[:, 2]) - np.interp(prev, tO, O[:, 2]))
inc = np.array([r["inc"] for r in rec])
meas = np.array([r[var] if r[var] is not None else np.nan for r in rec])
turn = np.abs(inc[:, 0]) < 1e-4
w = np.abs(inc[:, 2]) * 15
sd_o = math.radians(0.5) + 0.05 * w
var_o = np.where((np.abs(inc[:, 0]) > 0) | (np.abs(inc[:, 2]) > 0), (1 / 15) * sd_o ** 2 / 50, 0.0)
var_m = np.where(turn, sd_turn, sd_drive) ** 2 / F ** 2
tot = var_o + var_m
gate = np.isfinite(meas) & (meas ** 2 <= 9 * tot)
corr = np.where(gate, meas * var_o / tot, 0.0)
E_o = np.cumsum(eps); E_c = np.cumsum(eps - corr)
# position error at the end: heading error at frame k times the remaining path (odometric positions)
x = np.interp(t, tO, O[:, 0]); y = np.interp(t, tO, O[:, 1])
def endpos(E):
    dx = np.diff(x, prepend=x[0]); dy = np.diff(y, prepend=y[0])
    # lateral displacement accumulated: sum E_k * (R90 * step_k)
    ex = np.sum(-E * dy); ey = np.sum(E * dx)
    return math.hypot(ex, ey)
print(f"{name} {var} (sd {sd_turn}/{sd_drive}): final heading err odom {E_o[-1]*1e3:+.1f} corrected {E_c[-1]*1e3:+.1f} mrad; rms {np.sqrt((E_o**2).mean())*1e3:.1f} vs {np.sqrt((E_c**2).mean())*1e3:.1f}; heading-driven end position error {endpos(E_o):.3f} vs {endpos(E_c):.3f} m; gated out {np.sum(np.isfinite(meas) & ~gate)}")
