import sys, numpy as np, tempfile, pathlib
sys.path.insert(0, '/work/main')
from plant.calibration.bench_records import make_record
from plant.calibration.io import load_record
from plant.calibration.fit import prepare

K = 3
def harmonic_fit(t, v, K):
    """best fundamental and R² of a K-harmonic fit of v (>= 3 cycles)."""
    T = t[-1] - t[0]
    n = t.size
    vv = v - v.mean()
    spec = np.abs(np.fft.rfft(vv * np.hanning(n)))
    freqs = np.fft.rfftfreq(n, d=(t[1]-t[0]))
    ok = freqs >= 3.0 / T
    if not ok.any(): return None, 0.0
    i = np.argmax(np.where(ok, spec, 0))
    f_peak = freqs[i]
    best = (None, -1)
    for f in np.linspace(f_peak * 0.97, f_peak * 1.03, 61):
        cols = [np.ones_like(t)]
        for k in range(1, K + 1):
            cols += [np.sin(2*np.pi*k*f*t), np.cos(2*np.pi*k*f*t)]
        X = np.column_stack(cols)
        c, *_ = np.linalg.lstsq(X, v, rcond=None)
        r = v - X @ c
        r2 = 1 - (r @ r) / (vv @ vv)
        if r2 > best[1]: best = (f, r2)
    return best

for seed in [int(s) for s in sys.argv[1:]]:
    r = make_record(seed)
    d = pathlib.Path(tempfile.mkdtemp())
    r.write_csv(d / 'r.csv')
    prep = prepare(load_record(str(d / 'r.csv')))
    t = prep.t_dec - prep.t_dec[0]
    f, r2 = harmonic_fit(t, prep.dq_dec, K)
    print(seed, r.meta['trajectory'], r.hidden, 'f0=%.4f cycles=%.1f R2=%.3f' % (f or 0, (f or 0) * t[-1], r2), flush=True)
