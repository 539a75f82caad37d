import sys, os, tempfile, pathlib, json
from concurrent.futures import ProcessPoolExecutor
sys.path.insert(0, os.getcwd())
def one(arg):
    seed, hidden = arg
    from plant.calibration.bench_records import make_record
    from plant.calibration.fit import prepare
    from plant.calibration.io import load_record
    from plant.calibration.loop import run_loop, backlash_gap, friction_levels
    r = make_record(seed, hidden)
    d = pathlib.Path(tempfile.mkdtemp()); r.write_csv(d / "r.csv")
    res = run_loop(prepare(load_record(d / "r.csv")))
    m = r.meta; tm = m["two_mass"]
    b = r.truth["backlash"]["width_rad"]; k = tm["stiffness_nm_rad"]
    named = [a.kind for a in res.accepted]
    out = dict(seed=seed, traj=m["trajectory"], named=named, gap=b, k=k, fc=m["fc"], fs=m["fc"]*m["fs_ratio"],
               vs=m["vs"], vmax=m["vmax"], Jm=tm["J_m"], Jl=tm["J_l"], fres=tm["resonance_hz"], res=1/m["counts_per_rad"])
    if "backlash" in named and res.final.spec.backlash_width is not None:
        W = res.final.spec.backlash_width
        fcf, tsf = friction_levels(res.final)
        out.update(W=W, fc_fit=fcf, ts_fit=tsf, stribeck="stribeck" in res.final.names,
                   gap_fit=backlash_gap(W, fcf, tsf, k), gap_true_fric=backlash_gap(W, m["fc"], m["fc"]*m["fs_ratio"], k))
    return out
args = [(int(s), None) for s in sys.argv[2:]]
with ProcessPoolExecutor(2) as ex, open(sys.argv[1], "w") as fo:
    for o in ex.map(one, args):
        fo.write(json.dumps(o) + "\n"); fo.flush()
        if "W" in o:
            g = o["gap"]
            print(o["seed"], o["traj"], o["named"], f"gap {g:.3g} W {o['W']/g-1:+.0%} gapfit {o['gap_fit']/g-1:+.0%} gaptruefric {o['gap_true_fric']/g-1:+.0%} fc {o['fc_fit']/o['fc']-1:+.0%} ts {o['ts_fit']/o['fs']-1:+.0%} wind (fc+fs)/2k/gap {(o['fc']+o['fs'])/(2*o['k'])/g:.2f} Jl/Jm {o['Jl']/o['Jm']:.2f} fres {o['fres']:.0f}", flush=True)
        else:
            print(o["seed"], o["traj"], o["named"], flush=True)
