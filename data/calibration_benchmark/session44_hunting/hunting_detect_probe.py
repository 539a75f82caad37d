"""Session 44 probe: a hunting detector that reads the record alone, checked against the generator's truth.
For every record in the ranges: the share of moving decimated samples the detector flags; for the blind
staircases also per truth plateau (commanded speed from meta) the truth cv (std/|v| of the decimated velocity)
and the share of the plateau flagged.  Usage (repository root): python hunting_detect_probe.py OUT.json GEN:LO-HI..."""
import sys, os, json, importlib, tempfile, pathlib
import numpy as np
from scipy.ndimage import uniform_filter1d, maximum_filter1d, minimum_filter1d
sys.path.insert(0, os.getcwd()); sys.path.insert(0, str(pathlib.Path(__file__).resolve().parent.parent / "tools"))
from jobs import map_jobs, seed_jobs, GEN
from plant.calibration import io as cio, fit as F

P = dict(window_s=float(os.environ.get("HW", 2.0)), smooth_s=float(os.environ.get("HS", 0.5)))

def detect(t, w, v_still, window_s=2.0, smooth_s=0.5, cv_min=0.5, const_ratio=0.5):
    dt = float(np.median(np.diff(t)))
    ns = max(3, int(round(smooth_s / dt)) | 1); nw = max(5, int(round(window_s / dt)) | 1)
    sm = uniform_filter1d(w, ns, mode="nearest"); hf = w - sm
    m = uniform_filter1d(sm, nw, mode="nearest"); hrms = np.sqrt(np.maximum(uniform_filter1d(hf**2, nw, mode="nearest"), 0.0))
    smax = maximum_filter1d(sm, nw, mode="nearest"); smin = minimum_filter1d(sm, nw, mode="nearest")
    const = (smin * smax > 0) & (np.minimum(abs(smin), abs(smax)) >= const_ratio * np.maximum(abs(smin), abs(smax)))
    centre = const & (abs(m) > v_still) & (hrms > cv_min * abs(m))
    return maximum_filter1d(centre.astype(np.uint8), nw, mode="constant").astype(bool)

def detect_b(t, q, w, v_still, resolution, window_s=4.0, cv_min=0.5, const_ratio=0.5, min_counts=20):
    """Variant B: the window's speeds from the position (net displacement over the window and its halves), so a
    stick-slip slower than the smoothing is still one constant commanded speed; moving when the window travels
    at least min_counts position quanta (a plateau slower than the standstill threshold still counts)."""
    dt = float(np.median(np.diff(t)))
    h = max(2, int(round(window_s / dt / 2)))
    n = t.size
    i = np.arange(n); a = np.clip(i - h, 0, n - 1); b = np.clip(i + h, 0, n - 1)
    T1 = np.maximum(t[i] - t[a], 1e-12); T2 = np.maximum(t[b] - t[i], 1e-12)
    m1 = (q[i] - q[a]) / T1; m2 = (q[b] - q[i]) / T2; m = (q[b] - q[a]) / (T1 + T2)
    const = (m1 * m2 > 0) & (np.minimum(abs(m1), abs(m2)) >= const_ratio * np.maximum(abs(m1), abs(m2)))
    mu = uniform_filter1d(w, 2 * h + 1, mode="nearest"); m2w = uniform_filter1d(w * w, 2 * h + 1, mode="nearest")
    sd = np.sqrt(np.maximum(m2w - mu * mu, 0.0))
    sm = uniform_filter1d(w, max(3, int(round(1.0 / dt)) | 1), mode="nearest")
    smax = maximum_filter1d(sm, 2 * h + 1, mode="nearest"); smin = minimum_filter1d(sm, 2 * h + 1, mode="nearest")
    const &= ~((smin < -v_still) & (smax > v_still))   # no reversal inside the window
    travel = np.abs(q[b] - q[a]) >= min_counts * max(resolution, 1e-300)
    centre = const & travel & (sd > cv_min * np.abs(m)) & (np.abs(b - a) >= 2 * h)
    return maximum_filter1d(centre.astype(np.uint8), 2 * h + 1, mode="constant").astype(bool)

def one(job):
    gen, seed = job
    r = importlib.import_module(GEN[gen]).make_record(seed)
    d = pathlib.Path(tempfile.mkdtemp()); r.write_csv(d / "rec.csv")
    prep = F.prepare(cio.load_record(str(d / "rec.csv")))
    t = F._decimate_times(prep.t, prep.decim); w = F._decimate(prep.dq, prep.decim)
    v_still = 0.02 * float(np.percentile(np.abs(w), 95))
    flag = (F.hunting_mask(t, w, v_still, prep.position_resolution) if os.environ.get("VF") else detect_b(t, F._decimate(prep.q, prep.decim), w, v_still, prep.position_resolution, window_s=P["window_s"])
            if os.environ.get("VB") else detect(t, w, v_still, **P))
    # VF=1: the committed plant.calibration.fit.hunting_mask; VB=1: variant B (dropped); else variant A (first try)
    moving = np.abs(w) >= v_still
    out = {"gen": gen, "seed": seed, "traj": r.meta.get("trajectory"), "hidden": list(r.hidden),
           "flag_share": float((flag & moving).sum() / max(moving.sum(), 1)),
           "dwell": float(np.mean(np.abs(w[flag]) < v_still)) if flag.any() else None,
           "reverse": float(np.mean(np.sign(w[flag]) == -np.sign(np.median(w[flag])))) if flag.any() else None}
    pl = (r.meta.get("trajectory_info") or {}).get("plateaus") if gen == "blind" else None
    if pl:
        rows = []
        for t0, t1, v in pl:
            mm = (t > t0 + 1.0) & (t < t1 - 0.5)
            if mm.sum() < 20: continue
            rows.append((abs(v), float(np.std(w[mm]) / abs(v)), float(flag[mm].mean())))
        out["plateaus"] = rows
    return out

if __name__ == "__main__":
    out = map_jobs(one, seed_jobs(sys.argv[2:]), chunksize=4)
    json.dump(out, open(sys.argv[1], "w"), indent=1)
