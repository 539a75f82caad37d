import json, re, sys
rows = []
for p in sys.argv[1:]:
    for o in json.load(open(p)):
        own = {}
        for l in o['lines']:
            m = re.match(r"OWNSHARE (\S+) step (\d+) gain (\S+) z (\S+) ratio (\S+) proj (\S+) ownrms (\S+) resrms (\S+)", l)
            if m:
                own.setdefault((m[1], int(m[2])), []).append(tuple(float(x) for x in m.groups()[2:]))
            m = re.match(r"step (\d+): add (\S+) \(gain ([\d.]+)", l)
            if m and (m[2], int(m[1])) in own:
                g = float(m[3])
                cand = min(own[(m[2], int(m[1]))], key=lambda t: abs(t[0] - g))
                rows.append((o['generator'][:5], o['seed'], m[2], int(m[1]), m[2] in o['hidden'], cand))
for r in sorted(rows, key=lambda r: r[5][3]):
    g, s, k, st, tru, (gain, z, ratio, proj, ownrms, resrms) = r
    print(f"{g} {s} {k:18s} step {st} {'TRUE ' if tru else 'FALSE'} gain {gain:7.2f} z {z:4.1f} ratio {ratio:8.4f} proj {proj:7.4f} own/res {ownrms/resrms:.4f}")
