import sys; sys.path.insert(0,'.'); sys.path.insert(0,'data/calibration_benchmark/session25_sweep_guard')
import numpy as np
from plant.calibration import loop, residuals as res
calls=[]
orig=loop.cv_compare
def wrap(e0,e1,n_batches=40):
    out=orig(e0,e1,n_batches); calls.append((e0,e1,out)); return out
loop.cv_compare=wrap
prepbox=[]
origprep=loop.run_loop if hasattr(loop,'run_loop') else None
from runner import calibrate_record
gen, seed, target = sys.argv[1], sys.argv[2], float(sys.argv[3])
mod, r, rep, wall = calibrate_record(gen, seed)
for e0,e1,(g,z) in calls:
    if abs(g-target)<0.01:
        ex0=getattr(e0,'extrapolated',None); ex1=getattr(e1,'extrapolated',None)
        a0,a1=np.asarray(e0),np.asarray(e1)
        if ex0 is not None and ex1 is not None:
            u=~(ex1&~ex0); a0,a1=a0[u],a1[u]
        d=a0**2-a1**2
        B=min(40,d.size//25); ed=np.linspace(0,d.size,B+1).astype(int)
        bm=np.add.reduceat(d,ed[:-1])/np.diff(ed)
        print('n',d.size,'gain',g,'z',z)
        print('batch means / mean loss0 (%):', np.round(100*bm/np.mean(a0**2),1).tolist())
        break
