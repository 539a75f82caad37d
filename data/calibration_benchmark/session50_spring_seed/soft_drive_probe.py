import numpy as np
import os, sys
sys.path.insert(0, os.getcwd())
F_LO, F_HI = float(os.environ.get("F_LO", 3.0)), float(os.environ.get("F_HI", 6.0))
from plant.calibration.io import Record

def soft_drive_record(seed, fs=500.0, duration=80.0, n_legs=4):
    """Test's own: motor Jm -- spring K, damper c -- load Jl with friction Fc tanh(vl/1e-4) + Fv vl;
    a PI velocity loop on the motor encoder's differenced counts sets the motor torque, which is logged
    with noise; motor position quantised. Semi-implicit Euler at 20 sub-steps per control sample."""
    rng = np.random.default_rng(seed)
    jm, jl = rng.uniform(0.4, 0.8), rng.uniform(0.4, 0.8)
    f_res = rng.uniform(F_LO, F_HI)                      # Hz, the drive's first mode
    jr = jm * jl / (jm + jl)
    K = (2 * np.pi * f_res) ** 2 * jr
    c = 2 * 0.03 * np.sqrt(K * jr)                    # damping ratio 0.03
    fc, fv = rng.uniform(0.3, 1.0), rng.uniform(5.0, 20.0)
    vmax = rng.uniform(0.02, 0.05)
    gap = float(os.environ.get("GAP_REL", 0.0)) * rng.uniform(0.3, 1.0) * 2 * fc / K
    n = int(duration * fs); dt = 1.0 / fs; sub = 20; h = dt / sub
    t = np.arange(n) * dt
    leg = np.minimum((t / (duration / n_legs)).astype(int), n_legs - 1)
    sign = np.where(leg % 2 == 0, 1.0, -1.0)
    v_ref = vmax * sign
    k = int(1.0 * fs)                                  # 1 s ramps
    v_ref = np.convolve(np.pad(v_ref, (k, k), mode="edge"), np.ones(k) / k, mode="same")[k:-k]
    v_ref[: int(0.5 * fs)] = 0.0; v_ref[-int(0.5 * fs):] = 0.0
    quantum = 2 * np.pi / 2**22
    qm = ql = vm = vl = 0.0; integ = 0.0; q_prev = 0.0
    kp, ki = 8.0 * (jm + jl) * 2 * np.pi, 8.0 * (jm + jl) * (2 * np.pi) ** 2
    pos = np.empty(n); tau_log = np.empty(n)
    for i in range(n):
        qc = np.round(qm / quantum) * quantum
        v_meas = (qc - q_prev) / dt; q_prev = qc
        e = v_ref[i] - v_meas
        integ += ki * e * dt
        tau = kp * e + integ
        pos[i] = qc; tau_log[i] = tau
        for _ in range(sub):
            dl = qm - ql
            dz = dl - gap / 2 if dl > gap / 2 else (dl + gap / 2 if dl < -gap / 2 else 0.0)
            fs_ = K * dz + (c * (vm - vl) if dz != 0.0 else 0.0)
            fr = fc * np.tanh(vl / 1e-4) + fv * vl
            vm += h * (tau - fs_) / jm
            vl += h * (fs_ - fr) / jl
            qm += h * vm; ql += h * vl
    torque = tau_log + rng.normal(0.0, 0.02, n)
    soft_drive_record.gap = gap
    return Record(name=f"soft{seed}", t_s=t, position=pos, torque=torque), K

if __name__ == "__main__":
    import sys, os, tempfile, pathlib, dataclasses
    sys.path.insert(0, os.getcwd())
    from plant.calibration.fit import prepare
    from plant.calibration import loop as L
    for s in range(int(sys.argv[1]), int(sys.argv[2])):
        rec, K = soft_drive_record(s)
        prep = prepare(rec)
        cfg = dataclasses.replace(L.LoopConfig(), gear_stiffness=K)
        base, _ = L.fit_baseline(prep, cfg)
        res = L.run_loop(prep, None, cfg)
        print(s, "K", round(K), "gap", soft_drive_record.gap, "gap/windup", getattr(soft_drive_record, 'gap', 0) and soft_drive_record.gap / (2 * 0.65 / K), "base coulomb", round(L._coulomb(base), 4), "named", [e.kind for e in res.accepted] if hasattr(res, 'accepted') else res, flush=True)
