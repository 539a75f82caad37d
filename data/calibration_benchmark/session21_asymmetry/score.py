import json, sys
LIB={"asymmetric_friction","position_periodic","gravity_imbalance","presliding","backlash","time_periodic"}
def load(f):
    return {r['seed']: r for r in json.load(open(f))}
def exact(r): return set(r['named'])==set(r['hidden'])&LIB
a=load(sys.argv[1]); print(sys.argv[1], 'exact', sum(exact(r) for r in a.values()), '/', len(a),
   'clean invented', sum(1 for r in a.values() if not r['hidden'] and r['named']),
   'OOL with lib kind', sum(1 for r in a.values() if r['hidden'] and not set(r['hidden'])&LIB and r['named']))
if len(sys.argv)>2:
    b=load(sys.argv[2]); print(sys.argv[2], 'exact', sum(exact(r) for r in b.values() if r['seed'] in a), '/', len(b),
       'clean invented', sum(1 for r in b.values() if not r['hidden'] and r['named']),
       'OOL with lib kind', sum(1 for r in b.values() if r['hidden'] and not set(r['hidden'])&LIB and r['named']))
    for s in sorted(set(a)&set(b)):
        if a[s]['named']!=b[s]['named'] or exact(a[s])!=exact(b[s]):
            print('  ', s, a[s]['hidden'], a[s]['named'], '->', b[s]['named'], 'GAIN' if exact(b[s]) and not exact(a[s]) else ('LOSS' if exact(a[s]) and not exact(b[s]) else ''))
