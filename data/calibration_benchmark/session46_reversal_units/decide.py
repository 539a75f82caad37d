import json, sys
ch=json.load(open(sys.argv[1]))
mn=json.load(open(sys.argv[2]))
M={(o['generator'],o['seed']):o for o in mn}
LIB={'asymmetric_friction','position_periodic','gravity_imbalance','presliding','backlash','time_periodic'}
for g in ('independent','blind'):
    gained=lost=0
    ex_c=ex_m=0; clean_c=clean_m=0; ool_c=ool_m=0; n=0
    for o in ch:
        if o['generator']!=g: continue
        n+=1
        m=M.get((g,o['seed']),o)
        ex_c+=o['exact']; ex_m+=m['exact']
        if not o['hidden']:
            clean_c+=bool(o['named']); clean_m+=bool(m['named'])
        elif not (set(o['hidden'])&LIB):
            ool_c+=bool(set(o['named'])&LIB); ool_m+=bool(set(m['named'])&LIB)
        if o['exact']!=m['exact'] or o['named']!=m['named']:
            t='GAINED' if o['exact'] and not m['exact'] else 'LOST' if m['exact'] and not o['exact'] else 'changed'
            gained+=t=='GAINED'; lost+=t=='LOST'
            print(g,o['seed'],'hidden',o['hidden'],'main',m['named'],'change',o['named'],t)
    print(f"{g}: n {n} exact main {ex_m} change {ex_c}; gained {gained} lost {lost}; clean invented main {clean_m} change {clean_c}; OOL with a library kind main {ool_m} change {ool_c}")
