import sys, os, json, tempfile, importlib; sys.path.insert(0,'.')
import numpy as np
from plant.calibration.io import load_record
from plant.calibration import fit as F
from plant.calibration.residuals import reversal_dwell_swings
GEN = {"independent": "plant.calibration.bench_records", "blind": "plant.calibration.blind_records"}
gen=sys.argv[1]; cls=sys.argv[2]
for s in map(int, sys.argv[3:]):
    mod=importlib.import_module(GEN[gen]); r=mod.make_record(s)
    d=tempfile.mkdtemp(prefix='s45dw'); r.write_csv(d+'/rec.csv')
    prep=F.prepare(load_record(d+'/rec.csv'))
    base=F.fit_model(prep, F.ModelSpec(), refine=False)
    fc=base.param('coulomb')
    sw=reversal_dwell_swings(prep)/fc
    print(cls, gen, s, r.hidden, 'n', sw.size, 'median', round(float(np.median(sw)),2) if sw.size else None, np.round(sw[:8],2), flush=True)
