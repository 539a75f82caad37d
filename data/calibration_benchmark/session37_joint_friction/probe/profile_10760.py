"""Session 37 probe (used blind records): the two-mass rss over the gap, with the fit's friction and with
the generator's true friction on the load (true share and damping in both)."""
import sys, os, json, tempfile, pathlib, math
sys.path.insert(0, os.getcwd())
import numpy as np
import plant.calibration.blind_records as B
import plant.calibration.two_mass as tmm
import plant.calibration.report as rp

for s in map(int, sys.argv[1:]):
    cap = {}
    orig = rp.two_mass_gap
    def wrap(prep, fit, K, gap0, k):
        cap["a"] = (prep, fit, K, gap0, k); return None, {}
    rp.two_mass_gap = wrap
    r = B.make_record(s); m = r.meta; tm = m["two_mass"]
    d = pathlib.Path(tempfile.mkdtemp()); r.write_csv(d / "r.csv")
    rp.calibrate(d / "r.csv", d / "out", plots=False, gear_stiffness=tm["stiffness_nm_rad"])
    rp.two_mass_gap = orig
    prep, fit, K, gap0, k = cap["a"]
    T = tmm.TwoMass(prep, fit, K)
    share = tm["load_inertia_kg_m2"] / (tm["load_inertia_kg_m2"] + tm["motor_inertia_kg_m2"])
    z = tm["damping_ratio"]; truth = tm["backlash_width_rad"]
    fitf = T.friction
    true_f = tmm.LoadFriction(m["coulomb_pos_nm"], m["coulomb_neg_nm"], m["viscous_pos_nm_s_rad"], m["viscous_neg_nm_s_rad"],
                              m["static_pos_nm"] - m["coulomb_pos_nm"], m["stribeck_velocity_rad_s"], m["offset_nm"])
    print(s, "fit inertia", T.inertia, "true", m["inertia_kg_m2"], "\n fit friction", vars(fitf), "\n true friction", vars(true_f))
    gaps = truth * np.geomspace(0.25, 4, 17)
    for name, f in (("fit", fitf), ("true", true_f)):
        T.friction = f
        rs = []
        for g in gaps:
            rr = T.residual(share, z, float(g)); rs.append(float(rr @ rr))
        i = int(np.argmin(rs))
        print(f" {name:5s} friction: rss min at {gaps[i]/truth-1:+.0%} of truth;",
              " ".join(f"{g/truth:.2f}:{x:.4g}" for g, x in zip(gaps, rs)))
