import sys, pickle, numpy as np
from pathlib import Path
from flylog.metrics.truth import read_truth
F = 250.0
tag, name = sys.argv[1], sys.argv[2]
rec = [r for r in pickle.load(open(f"/tmp/lead7/runs/{tag}/{name}.pkl", "rb")) if r["t"] is not None]
tr = read_truth(Path(f"/tmp/lead7/runs/{tag}/runs/{name}.mcap"))
tT = np.asarray(tr.true.t_ns); th = np.unwrap(np.asarray(tr.true.xyt)[:, 2])
tO = np.asarray(tr.odom.t_ns); tho = np.unwrap(np.asarray(tr.odom.xyt)[:, 2])
t = np.array([r["t"] for r in rec]); prev_t = t - round(1e9 / 15)
eps_true = (np.interp(t, tT, th) - np.interp(prev_t, tT, th)) - (np.interp(t, tO, tho) - np.interp(prev_t, tO, tho))
inc = np.array([r["inc"] for r in rec]); tx, dth = inc[:, 0], inc[:, 2]
d_odo = np.interp(t, tO, tho) - np.interp(prev_t, tO, tho)
print("inc vs log odometry increment: max |diff| px", np.abs(dth - d_odo).max() * F, " prev stamps match:", np.mean(np.diff(t) == round(1e9/15)))
turn = np.abs(tx) < 1e-4
if "nground" in rec[0]: print("ground flies per frame: median", np.median([r["nground"] for r in rec]))
for var in [k for k in ("all", "d6", "ref", "ground", "w5") if k in rec[0]]:
  m = np.array([r[var] if r[var] is not None else np.nan for r in rec])
  e = (m - eps_true) * F
  print("==", var, "sd(err) turn %.3f drive %.3f" % (np.nanstd(e[turn]), np.nanstd(e[~turn])))
  for lab, sel in (("turn+", turn & (dth > 1e-3)), ("turn-", turn & (dth < -1e-3)), ("drive w+", ~turn & (dth > 3e-3)), ("drive w-", ~turn & (dth < -3e-3)), ("drive straight", ~turn & (np.abs(dth) <= 3e-3))):
    ok = sel & np.isfinite(e)
    if ok.sum() == 0: continue
    print(f"{lab:15s} n={ok.sum():4d} bias {e[ok].mean():+.4f} ± {e[ok].std()/np.sqrt(max(ok.sum(),1)):.4f} px  mean dth {dth[ok].mean()*F:+.2f}px mean v {tx[ok].mean()*15:.2f} m/s")
