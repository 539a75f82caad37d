"""Session 61's fifth bar and every changed named set: CHANGE.json against MAIN.json (both on every record).
Usage: python bar5.py CHANGE.json MAIN.json"""
import json, sys
REV = {"presliding", "backlash"}
ch = {(o["generator"], o["seed"]): o for o in json.load(open(sys.argv[1]))}
mn = {(o["generator"], o["seed"]): o for o in json.load(open(sys.argv[2]))}
assert set(ch) == set(mn), "the two runs must cover the same records"
wrong_rev = lambda o: bool((set(o["named"]) - set(o["hidden"])) & REV)
for g in ("independent", "blind"):
    ks = sorted(k for k in ch if k[0] == g)
    print(f"{g}: records naming a reversal kind they do not hide: main {sum(wrong_rev(mn[k]) for k in ks)}, "
          f"change {sum(wrong_rev(ch[k]) for k in ks)}")
    for k in ks:
        if set(ch[k]["named"]) != set(mn[k]["named"]):
            print(f"   {k[1]} hidden {ch[k]['hidden']} main {mn[k]['named']} change {ch[k]['named']} "
                  f"exact {mn[k]['exact']} -> {ch[k]['exact']}")
