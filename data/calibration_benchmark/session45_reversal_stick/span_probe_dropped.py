import sys, os, json, tempfile, importlib; sys.path.insert(0,'.')
import numpy as np
from plant.calibration.io import load_record
from plant.calibration import fit as F
GEN = {"independent": "plant.calibration.bench_records", "blind": "plant.calibration.blind_records"}

def spans(prep, max_gap_s=1.0):
    dq=prep.dq; y=prep.y; pos=prep.record.position[-dq.size:]; t=prep.t
    res=prep.position_resolution
    v_still=0.02*float(np.percentile(np.abs(dq),95))
    mov=np.abs(dq)>=v_still
    sg=np.sign(dq)*mov
    # moving runs
    edges=np.flatnonzero(np.diff(np.r_[0, mov.astype(np.int8), 0]))
    runs=[(a,b,np.sign(np.median(dq[a:b]))) for a,b in zip(edges[::2],edges[1::2]) if (b-a)*prep.dt_s>=0.1]
    out=[]
    for (a1,b1,s1),(a2,b2,s2) in zip(runs[:-1],runs[1:]):
        if s1==s2 or s1==0 or s2==0: continue
        if (a2-b1)*prep.dt_s>max_gap_s: continue
        m=max(3,int(0.05/prep.dt_s))
        lo=max(a1,b1-m); hi=min(b2,a2+m)
        tb=np.median(y[lo:b1]); ta=np.median(y[a2:hi])
        sw=ta-tb
        if abs(sw)<1e-12: continue
        seg=(y[b1-m if b1-m>a1 else a1:hi]-tb)/sw  # 0 before, 1 after
        i0=b1-m if b1-m>a1 else a1
        c25=np.flatnonzero(seg>=0.25); c75=np.flatnonzero(seg>=0.75)
        if not c25.size or not c75.size: continue
        i25=i0+c25[0]; i75=i0+c75[0]
        if i75<i25: i25,i75=i75,i25
        p=pos[i25:i75+1]
        out.append(((p.max()-p.min())/res if res>0 else np.nan, (i75-i25)*prep.dt_s))
    return out

def one(gen, seed):
    mod=importlib.import_module(GEN[gen])
    r=mod.make_record(seed)
    d=tempfile.mkdtemp(prefix='s45span'); r.write_csv(d+'/rec.csv')
    rec=load_record(d+'/rec.csv'); prep=F.prepare(rec)
    sp=spans(prep)
    m=r.meta; tr=r.truth
    fcs = (m.get('coulomb_nm') or m.get('fc_nm') or 0)
    return sp, r.hidden, m.get('trajectory') or m.get('trajectory_kind'), tr.get('presliding')
if __name__=='__main__':
    gen=sys.argv[1]
    for s in map(int, sys.argv[2:]):
        sp,h,tk,trp=one(gen,s)
        a=np.array(sp) if sp else np.zeros((0,2))
        med=np.median(a[:,0]) if a.size else None
        print(gen, s, h, tk, 'n_rev', len(sp), 'median span counts', None if med is None else round(float(med),1), 'q25/q75', np.round(np.percentile(a[:,0],[25,75]),1) if a.size else None, 'median dur ms', round(1e3*float(np.median(a[:,1])),1) if a.size else None, trp)
