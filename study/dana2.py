import sys, pickle, numpy as np
from pathlib import Path
from flylog.metrics.truth import read_truth
F = 250.0
tag, name = sys.argv[1], sys.argv[2]
rec = [r for r in pickle.load(open(f"/tmp/lead7/runs/{tag}/{name}.pkl", "rb")) if r["t"] is not None]
tr = read_truth(Path(f"/tmp/lead7/runs/{tag}/runs/{name}.mcap"))
tT = np.asarray(tr.true.t_ns); th = np.unwrap(np.asarray(tr.true.xyt)[:, 2])
tO = np.asarray(tr.odom.t_ns); tho = np.unwrap(np.asarray(tr.odom.xyt)[:, 2])
t = np.array([r["t"] for r in rec]); true = np.interp(t, tT, th); odo = np.interp(t, tO, tho)
prev_t = t - round(1e9 / 15)
eps_true = (true - np.interp(prev_t, tT, th)) - (odo - np.interp(prev_t, tO, tho))
tx = np.array([r["inc"][0] for r in rec]); dth = np.array([r["inc"][2] for r in rec])
turn = np.abs(tx) < 1e-4
for v in ("all", "d10", "d6", "d4"):
    m = np.array([r[v] if r[v] is not None else np.nan for r in rec])
    for lab, sel in (("turn", turn), ("drive", ~turn)):
        ok = sel & np.isfinite(m)
        e = (m[ok] - eps_true[ok]) * F
        # scale error: regress error on odometry turn per frame
        slope = np.polyfit(dth[ok] * F, e, 1)[0] if ok.sum() > 5 else np.nan
        print(f"{v:4s} {lab:5s} n={ok.sum():4d} bias {e.mean():+.4f}px sd {e.std():.3f} corr {np.corrcoef(m[ok], eps_true[ok])[0,1]:.2f} err-vs-turn slope {slope*100:+.2f}% sum(err) {e.sum()/F*1e3:+.1f} mrad (odometry sum {eps_true[ok].sum()*1e3:+.1f})")
