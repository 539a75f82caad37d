import sys, math; sys.path.insert(0,'.')
import numpy as np
from numba import njit
from plant.calibration.bench_records import make_record
seed=int(sys.argv[1]) if len(sys.argv)>1 else 33
r=make_record(seed); m=r.meta; tm=m['two_mass']
t=r.t_s; q=r.position_rad; y=r.torque_nm; dt=t[1]-t[0]
@njit(cache=False)
def sim(q, dt, nsub, Jl, K, c, gh, fc, fs, vs, fv, mode):
    n=q.size; h=dt/nsub; ql=q[0]; wl=0.0; out=np.zeros(n); qlo=np.zeros(n)
    qprev=q[0]
    for i in range(n):
        q0=q[i-1] if i>0 else q[0]; q1=q[i]; wm=(q1-q0)/dt
        for s in range(nsub):
            qm=q0+(q1-q0)*(s+1)/nsub
            d=qm-ql
            if d>gh: tc=K*(d-gh)+c*(wm-wl)
            elif d<-gh: tc=K*(d+gh)+c*(wm-wl)
            else: tc=0.0
            g=fc+(fs-fc)*math.exp(-(wl/vs)**2)
            # Karnopp stick
            if abs(wl)<1e-6 and abs(tc)<=fs:
                wl=0.0; fr=tc
            else:
                fr=(g*np.sign(wl) if wl!=0 else fs*np.sign(tc))+fv*wl
            wn=wl+h*(tc-fr)/Jl
            if wl!=0 and wn*wl<0: wn=0.0
            wl=wn; ql+=h*wl
        out[i]=tc; qlo[i]=ql
    return out,qlo
ddq=np.gradient(np.gradient(q,dt),dt)
from scipy.signal import butter, filtfilt
b,a=butter(4,20*2*dt)
qf=filtfilt(b,a,q); ddqf=np.gradient(np.gradient(qf,dt),dt)
true=r.truth['backlash']['width_rad']
for g in np.r_[0.3,0.5,0.7,0.85,1.0,1.15,1.3,1.6]*true:
    tc,_=sim(qf,dt,100,tm['J_l'],tm['stiffness_nm_rad'],tm['damping_nms_rad'],g/2,m['fc'],m['fc']*m['fs_ratio'],m['vs'],m['fv'],0)
    X=np.column_stack([ddqf, tc, np.ones_like(q)]+([np.sin(2*np.pi*r.truth['time_periodic']['frequency_hz']*t), np.cos(2*np.pi*r.truth['time_periodic']['frequency_hz']*t)] if 'time_periodic' in r.truth else []))
    X=filtfilt(b,a,X,axis=0); yf=filtfilt(b,a,y)
    sl=slice(100,-100)
    coef,*_=np.linalg.lstsq(X[sl],yf[sl],rcond=None)
    res=yf[sl]-X[sl]@coef
    print('gap %.3g rss %.5g  Jm %.3f ktc %.3f'%(g, res@res, coef[0], coef[1]))
print('J_m true',tm['J_m'])
def scan(label, Jl, fs, c=tm['damping_nms_rad'], nsub=100):
    best=None
    for g in np.r_[0.3,0.5,0.7,0.85,1.0,1.15,1.3,1.6]*true:
        tc,_=sim(qf,dt,nsub,Jl,tm['stiffness_nm_rad'],c,g/2,m['fc'],fs,m['vs'],m['fv'],0)
        X=np.column_stack([ddqf, tc, np.ones_like(q)]+([np.sin(2*np.pi*r.truth['time_periodic']['frequency_hz']*t), np.cos(2*np.pi*r.truth['time_periodic']['frequency_hz']*t)] if 'time_periodic' in r.truth else []))
        X=filtfilt(b,a,X,axis=0); yf=filtfilt(b,a,y); sl=slice(100,-100)
        coef,*_=np.linalg.lstsq(X[sl],yf[sl],rcond=None); res=yf[sl]-X[sl]@coef; rs=res@res
        if best is None or rs<best[1]: best=(g,rs)
    print(label,'best gap %.3g (%.0f%%) rss %.4g'%(best[0],100*(best[0]/true-1),best[1]))
scan('full',tm['J_l'],m['fc']*m['fs_ratio'])
scan('no stribeck',tm['J_l'],m['fc'])
scan('light load + stribeck',tm['J_l']*0.05,m['fc']*m['fs_ratio'],nsub=1000)
scan('light load no stribeck',tm['J_l']*0.05,m['fc'],nsub=1000)
print('---')
J=m['J']
for frac in [0.2,0.33,0.5,0.67,0.8]:
    for cc in [0.0, tm['damping_nms_rad']]:
        scan(f'frac {frac} c {cc:.0f}', J*frac, m['fc'], c=cc, nsub=200)
