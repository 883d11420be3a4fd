#!/usr/bin/env python3
"""Lists the interpd_motion items the given source folders name: `use interpd_motion::…`
statements (braces expanded) and inline paths `interpd_motion::a::b`, outside tests; the count
goes to stderr. How much of the motion crate another crate leans on:

    python3 scripts/crate-imports.py daemon/src sim/src
"""
import re, sys, pathlib
names = set()
def expand(prefix, body):
    # split top-level commas in body
    depth, cur, parts = 0, '', []
    for ch in body:
        if ch == '{': depth += 1
        if ch == '}': depth -= 1
        if ch == ',' and depth == 0:
            parts.append(cur); cur = ''
        else: cur += ch
    parts.append(cur)
    for p in parts:
        p = p.strip()
        if not p: continue
        m = re.match(r'^([\w:]*?)::?\{(.*)\}$', p, re.S)
        if m:
            expand(prefix + '::' + m.group(1) if m.group(1) else prefix, m.group(2)); continue
        p = re.sub(r'\s+as\s+\w+$', '', p)
        names.add(prefix if p == 'self' else prefix + '::' + p)
for d in sys.argv[1:]:
    for f in pathlib.Path(d).rglob('*.rs'):
        if f.name == 'tests.rs' or '/tests/' in str(f): continue
        text = f.read_text()
        text = re.split(r'#\[cfg\(test\)\]\s*mod tests', text)[0]
        for m in re.finditer(r'use\s+interpd_motion::(.*?);', text, re.S):
            body = m.group(1).strip()
            if body.startswith('{'): expand('interpd_motion', body[1:-1])
            else:
                mm = re.match(r'^(.*?)::\{(.*)\}$', body, re.S)
                if mm: expand('interpd_motion::' + mm.group(1), mm.group(2))
                else: expand('interpd_motion', body)
        for m in re.finditer(r'(?<!use )\binterpd_motion((?:::\w+)+)', text):
            # inline path: drop a trailing method/field (lowercase after a type)
            parts = m.group(1).strip(':').split('::')
            out = []
            for p in parts:
                out.append(p)
                if p[:1].isupper(): break
            names.add('interpd_motion::' + '::'.join(out))
for n in sorted(names): print(n)
print(len(names), 'names', file=sys.stderr)
