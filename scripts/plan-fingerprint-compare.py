#!/usr/bin/env python3
"""plan-fingerprint-compare.py BEFORE AFTER (files of scripts/plan-fingerprint.sh): durations must agree to 1e-9 s; reports CSV hash differences separately."""
import sys
def load(p):
    d={}
    for line in open(p):
        parts=line.split()
        if parts[0]=='law': d[('law',parts[1])]={'hash':parts[2]}; continue
        key=(parts[0],parts[1]); f=dict(x.split('=',1) for x in parts[2:]); d[key]=f
    return d
a,b=load(sys.argv[1]),load(sys.argv[2])
bad=0; csvdiff=0
for k in a:
    if k not in b: print('missing',k); bad+=1; continue
    x,y=a[k],b[k]
    if 'hash' in x:
        if x['hash']!=y['hash']: print('law output differs',k); bad+=1
        continue
    if x['rc']!=y['rc']: print('exit code differs',k,x['rc'],y['rc']); bad+=1; continue
    if x['dur']!='-' and abs(float(x['dur'])-float(y['dur']))>1e-9: print('duration differs',k,x['dur'],y['dur']); bad+=1
    if x['csv']!=y['csv']: csvdiff+=1
print(f'{len(a)} cases: {bad} differ in duration/exit/law output; {csvdiff} setpoint CSVs not byte-identical')
sys.exit(1 if bad else 0)
