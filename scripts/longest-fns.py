#!/usr/bin/env python3
"""Prints the N longest Rust functions (lines from `fn` to its closing brace) under the given
folders, with file and line:

    python3 scripts/longest-fns.py 12 motion/src daemon/src otg/src
"""
import re, sys, pathlib
rows = []
for d in sys.argv[2:]:
    for f in pathlib.Path(d).rglob('*.rs'):
        if 'target' in f.parts: continue
        lines = f.read_text().split('\n')
        i = 0
        while i < len(lines):
            m = re.match(r'^\s*(pub(\([\w:]+\))?\s+)?(const\s+|async\s+|unsafe\s+)*fn\s+(\w+)', lines[i])
            if m:
                depth, started, j = 0, False, i
                while j < len(lines):
                    code = re.sub(r'//.*', '', lines[j])
                    code = re.sub(r'"(\\.|[^"\\])*"', '""', code)
                    code = re.sub(r"'(\\.|[^'\\])'", "''", code)
                    if not started and ';' in code and '{' not in code: break
                    depth += code.count('{') - code.count('}')
                    if '{' in code: started = True
                    if started and depth <= 0: break
                    j += 1
                if started: rows.append((j - i + 1, f'{f}:{i+1}', m.group(4)))
                i = j + 1 if started else i + 1
            else: i += 1
rows.sort(reverse=True)
for n, where, name in rows[:int(sys.argv[1])]: print(f'{n:5} {name:32} {where}')
