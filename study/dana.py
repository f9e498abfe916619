import sys, pickle, math, numpy as np
from pathlib import Path
from flylog.metrics.truth import read_truth
F = 250.0
tag, name = sys.argv[1], sys.argv[2]
rec = pickle.load(open(f"/tmp/lead7/runs/{tag}/{name}.pkl", "rb"))
tr = read_truth(Path(f"/tmp/lead7/runs/{tag}/runs/{name}.mcap"))
tT = np.asarray(tr.true.t_ns); th = np.unwrap(np.asarray(tr.true.xyt)[:, 2])
tO = np.asarray(tr.odom.t_ns); tho = np.unwrap(np.asarray(tr.odom.xyt)[:, 2])
t = np.array([r["t"] for r in rec])
true = np.interp(t, tT, th); odo = np.interp(t, tO, tho)
est = np.unwrap(np.array([r["after"] for r in rec]))
print("final heading err: odom %.1f mrad, estimate %.1f mrad" % ((odo[-1]-true[-1])*1e3, (est[-1]-true[-1])*1e3))
# per-frame: eps_true = true increment - predicted increment (inc.theta)
rows = []
for i in range(1, len(rec)):
    r = rec[i]
    if r["inc"] is None or r["meas"] is None: continue
    eps_true = (true[i] - true[i-1]) - r["inc"][2] - ((est[i-1]-true[i-1]) - 0)*0  # heading increment error vs predicted
    # the predicted increment is from the corrected previous pose: eps_true = true inc - predicted inc
    rows.append((r["t"]/1e9, r["inc"][0], r["inc"][2], eps_true*F, r["meas"]*F, r["var"]))
a = np.array(rows)
turn = np.abs(a[:,1]) < 1e-4
for lab, m in (("turn", turn), ("drive", ~turn)):
    e = a[m,4]-a[m,3]
    print(f"{lab}: n={m.sum()} sd(eps_true)={a[m,3].std():.3f}px  bias(meas-true)={e.mean():+.3f}px sd={e.std():.3f} corr={np.corrcoef(a[m,3],a[m,4])[0,1]:.2f}")
# error of the estimate over time
for tt in (5, 10, 15, 20, 30, 40, 60, 80):
    k = np.searchsorted(t/1e9, tt)
    if k < len(t): print(f"t={tt}: odom err {(odo[k]-true[k])*1e3:+.1f} est err {(est[k]-true[k])*1e3:+.1f} mrad")
print("--- with the odometry interpolated at both stamps (after the fact)")
inc = np.array([r["inc"][2] if r["inc"] is not None else np.nan for r in rec])
meas = np.array([r["meas"] if r["meas"] is not None else np.nan for r in rec])
tx = np.array([r["inc"][0] if r["inc"] is not None else np.nan for r in rec])
d_odo = np.r_[np.nan, np.diff(odo)]; d_true = np.r_[np.nan, np.diff(true)]
extrap = inc - d_odo
ok = np.isfinite(meas) & np.isfinite(inc)
print("extrapolation error per frame px: sd %.3f, max %.3f" % (np.nanstd(extrap[ok]) * F, np.nanmax(np.abs(extrap[ok])) * F))
vis = inc + meas  # measured true rotation
eps_true = d_true - d_odo; eps_meas = vis - d_odo
for lab, m in (("turn", ok & (np.abs(tx) < 1e-4)), ("drive", ok & (np.abs(tx) >= 1e-4))):
    e = (eps_meas - eps_true)[m] * F
    print(f"{lab}: n={m.sum()} sd(eps_true) {eps_true[m].std()*F:.3f}px  meas-true bias {e.mean():+.4f} sd {e.std():.3f} corr {np.corrcoef(eps_true[m], eps_meas[m])[0,1]:.2f}  sum(eps_true) {eps_true[m].sum()*1e3:+.1f} mrad sum(err) {e.sum()/F*1e3:+.1f} mrad")
