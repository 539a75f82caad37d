import json, sys
LIB={"asymmetric_friction","position_periodic","gravity_imbalance","presliding","backlash","time_periodic"}
def score(path):
    d=json.load(open(path)); d=d['records'] if isinstance(d,dict) else d
    res={}
    for r in d:
        h=set(r['hidden'])&LIB; n=set(r['named'])&LIB
        kind = 'clean' if not r['hidden'] else ('ool' if not (set(r['hidden'])&LIB) else 'lib')
        res[r['seed']]=(n==h, kind, sorted(r['hidden']), sorted(r['named']))
    return res
a=score(sys.argv[1]); 
def summ(x):
    ex=sum(v[0] for v in x.values()); cl=[s for s,v in x.items() if v[1]=='clean' and not v[0]]
    ool=sum(v[0] for v in x.values() if v[1]=='ool'); nool=sum(1 for v in x.values() if v[1]=='ool')
    return f"exact {ex}/{len(x)}  clean invented {len(cl)}/{sum(1 for v in x.values() if v[1]=='clean')} {cl}  OOL ok {ool}/{nool}"
print(sys.argv[1], summ(a))
if len(sys.argv)>2:
    b=score(sys.argv[2]); print(sys.argv[2], summ(b))
    for s in sorted(a):
        if s in b and a[s][0]!=b[s][0]:
            print(('GAINED' if a[s][0] else 'LOST  '), s, a[s][2], 'new:',a[s][3], 'ref:', b[s][3])
