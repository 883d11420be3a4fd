#!/usr/bin/env python3
"""module-cycles.py [ROOT]: import cycles between the files of one folder of `*/src/**`.

For every crate of the workspace (ROOT, by default the repository this script is in) it
follows the `mod` declarations from `lib.rs`, `main.rs` and `src/bin/*.rs`, and for every
module file finds the sibling files it imports from: `use super::x::…`, `super::x::…` and
`crate::a::b::x::…` paths in the code, `use x::…` in the folder's own module, and `super::Name`
/ `crate::Name` through the own module's (re-)exports to the file that defines `Name`. The
folder's own module is its `mod.rs`, `lib.rs`/`main.rs` for `src/`, or `x.rs` beside `x/`.

It prints every cycle among the files of one folder (A → B → A and longer), each edge with the
line that makes it, and exits 1 if there is any.

Not counted: test code (`#[cfg(test)]` items, hence `mod tests` blocks and `tests.rs` files),
comments, strings and doc links, and the own module's imports from its children: declaring,
re-exporting and calling its children is what a parent module is for, so only the direction
child → parent is an import between files.
"""

import os
import re
import sys

IDENT = r"[A-Za-z_][A-Za-z0-9_]*"
KEYWORD_ROOTS = ("crate", "super", "self")


def strip(text):
    """The text with comments, strings and char literals blanked (newlines kept)."""
    out = list(text)
    i, n = 0, len(text)

    def blank(a, b):
        for k in range(a, b):
            if out[k] != "\n":
                out[k] = " "

    while i < n:
        c = text[i]
        if text.startswith("//", i):
            j = text.find("\n", i)
            j = n if j < 0 else j
            blank(i, j)
            i = j
        elif text.startswith("/*", i):
            depth, j = 1, i + 2
            while j < n and depth:
                if text.startswith("/*", j):
                    depth, j = depth + 1, j + 2
                elif text.startswith("*/", j):
                    depth, j = depth - 1, j + 2
                else:
                    j += 1
            blank(i, j)
            i = j
        elif (m := re.compile(r'b?r(#*)"').match(text, i)) and (i == 0 or not re.match(r"\w", text[i - 1])):
            end = text.find('"' + m.group(1), m.end())
            j = n if end < 0 else end + 1 + len(m.group(1))
            blank(i, j)
            i = j
        elif c == '"':
            j = i + 1
            while j < n and text[j] != '"':
                j += 2 if text[j] == "\\" else 1
            blank(i, j + 1)
            i = j + 1
        elif c == "'":
            m = re.compile(r"'(\\(x[0-9a-fA-F]{2}|u\{[0-9a-fA-F]+\}|.)|[^\\'])'").match(text, i)
            if m:
                blank(i, m.end())
                i = m.end()
            else:
                i += 1  # a lifetime
        else:
            i += 1
    return "".join(out)


def matching(text, i, open_="{", close="}"):
    """The index after the bracket that closes the one at i."""
    depth = 0
    for j in range(i, len(text)):
        if text[j] == open_:
            depth += 1
        elif text[j] == close:
            depth -= 1
            if depth == 0:
                return j + 1
    return len(text)


def item_end(text, i):
    """The end of the item starting at i: its `;`, or the `}` closing its body."""
    depth = 0
    for j in range(i, len(text)):
        c = text[j]
        if c in "([":
            depth += 1
        elif c in ")]":
            depth -= 1
        elif depth == 0 and c == ";":
            return j + 1
        elif depth == 0 and c == "{":
            return matching(text, j)
    return len(text)


def drop_test_code(text):
    """Blanks every item under `#[cfg(test)]`."""
    attr = re.compile(r"#\s*\[\s*cfg\s*\(\s*test\s*\)\s*\]")
    while m := attr.search(text):
        j = m.end()
        while True:  # further attributes of the same item
            k = re.compile(r"\s*#\s*\[").match(text, j)
            if not k:
                break
            j = matching(text, k.end() - 1, "[", "]")
        end = item_end(text, j)
        text = text[: m.start()] + "".join(ch if ch == "\n" else " " for ch in text[m.start() : end]) + text[end:]
    return text


def parse_use_tree(s):
    """`a::{b, c::d as e, f::*}` → [(["a", "b"], None), (["a", "c", "d"], "e"), (["a", "f", "*"], None)]."""
    tokens = re.findall(IDENT + r"|::|[{},*]", s)
    pos = 0

    def tree(prefix):
        nonlocal pos
        out = []
        path = list(prefix)
        while pos < len(tokens):
            t = tokens[pos]
            if t == "::":
                pos += 1
            elif t == "{":
                pos += 1
                while pos < len(tokens) and tokens[pos] != "}":
                    out += tree(path)
                    if pos < len(tokens) and tokens[pos] == ",":
                        pos += 1
                pos += 1
                return out
            elif t in ",}":
                break
            elif t == "as":
                alias = tokens[pos + 1] if pos + 1 < len(tokens) else None
                pos += 2
                return out + [(path, alias)]
            else:
                path.append(t)
                pos += 1
        return out + [(path, None)] if len(path) > len(prefix) else out

    return tree([])


class Module:
    def __init__(self, file, crate, modpath, own_dir):
        self.file = file  # path relative to ROOT
        self.crate = crate  # the crate root's file
        self.modpath = modpath  # tuple of module names from the crate root
        self.own_dir = own_dir  # the folder its child files live in
        self.text = ""
        self.inline = []  # (start, end, name) of non-test inline modules
        self.uses = []  # (pos, scope, segments, alias)
        self.paths = []  # (pos, scope, segments) of paths in the code
        self.children = {}  # name → modpath of declared child modules
        self.defined = set()  # names of items defined at top level
        self.line_starts = []

    def line(self, pos):
        lo, hi = 0, len(self.line_starts)
        while lo + 1 < hi:
            mid = (lo + hi) // 2
            if self.line_starts[mid] <= pos:
                lo = mid
            else:
                hi = mid
        return lo + 1

    def scope_at(self, pos):
        return self.modpath + tuple(name for a, b, name in self.inline if a <= pos < b)


def load_crate(root, root_file, modules):
    """Walks the `mod` declarations from one crate root."""
    crate = root_file
    todo = [(root_file, ())]
    while todo:
        rel, modpath = todo.pop()
        if (crate, modpath) in modules:
            continue
        base = os.path.basename(rel)
        here = os.path.dirname(rel)
        own_dir = here if base in ("lib.rs", "main.rs", "mod.rs") or modpath == () else os.path.join(here, base[:-3])
        m = Module(rel, crate, modpath, own_dir)
        modules[(crate, modpath)] = m
        with open(os.path.join(root, rel), encoding="utf-8") as f:
            raw = f.read()
        text = drop_test_code(strip(raw))
        m.text = text
        m.line_starts = [0] + [k + 1 for k, ch in enumerate(raw) if ch == "\n"]
        for d in re.finditer(r"\bmod\s+(" + IDENT + r")\s*([;{])", text):
            name = d.group(1)
            if d.group(2) == "{":
                m.inline.append((d.end() - 1, matching(text, d.end() - 1), name))
                continue
            m.children[name] = modpath + (name,)
            for cand in (os.path.join(own_dir, name + ".rs"), os.path.join(own_dir, name, "mod.rs")):
                if os.path.exists(os.path.join(root, cand)):
                    todo.append((cand, modpath + (name,)))
                    break
        for d in re.finditer(
            r"^\s*(?:pub(?:\s*\([^)]*\))?\s+)?(?:unsafe\s+)?(?:const\s+)?(?:fn|struct|enum|union|trait|type|const|static|mod)\s+("
            + IDENT
            + r")",
            text,
            re.M,
        ):
            m.defined.add(d.group(1))
        for d in re.finditer(r"\bmacro_rules!\s*(" + IDENT + r")", text):
            m.defined.add(d.group(1))
        spans = []
        for u in re.finditer(r"\buse\s+", text):
            if re.match(r"\w", text[u.start() - 1 : u.start()] or " "):
                continue
            end = item_end(text, u.end())
            scope = m.scope_at(u.start())
            for segs, alias in parse_use_tree(text[u.end() : end - 1]):
                m.uses.append((u.start(), scope, segs, alias))
            spans.append((u.start(), end))
        masked = list(text)
        for a, b in spans:
            for k in range(a, b):
                if masked[k] != "\n":
                    masked[k] = " "
        masked = "".join(masked)
        path_re = re.compile(r"(?<![\w:$.'])(" + IDENT + r"(?:\s*::\s*" + IDENT + r")+)")
        for p in path_re.finditer(masked):
            segs = re.split(r"\s*::\s*", p.group(1))
            m.paths.append((p.start(), m.scope_at(p.start()), segs))


def load_all(root):
    modules = {}
    for top in sorted(os.listdir(root)):
        src = os.path.join(top, "src")
        if top.startswith(".") or top == "target" or not os.path.isdir(os.path.join(root, src)):
            continue
        roots = [os.path.join(src, f) for f in ("lib.rs", "main.rs") if os.path.exists(os.path.join(root, src, f))]
        bin_dir = os.path.join(root, src, "bin")
        if os.path.isdir(bin_dir):
            roots += [os.path.join(src, "bin", f) for f in sorted(os.listdir(bin_dir)) if f.endswith(".rs")]
        for r in roots:
            load_crate(root, r, modules)
    return modules


class Resolver:
    def __init__(self, modules):
        self.modules = modules
        self.inline = {}  # (crate, scope) → module whose file holds that inline module
        for m in modules.values():
            for a, b, name in m.inline:
                self.inline[(m.crate, m.scope_at(a) + (name,))] = m

    def absolute(self, m, scope, segs):
        """The absolute path of `segs` written in `scope` of `m`, or None (an external path)."""
        if not segs:
            return None
        first = segs[0]
        if first == "crate":
            return list(segs[1:])
        if first in ("self", "super"):
            cur = list(scope)
            rest = list(segs)
            while rest and rest[0] in ("self", "super"):
                if rest.pop(0) == "super":
                    if not cur:
                        return None
                    cur.pop()
            return cur + rest
        if self.is_module(m.crate, tuple(scope) + (first,)):
            return list(scope) + list(segs)
        return None

    def is_module(self, crate, modpath):
        return (crate, modpath) in self.modules or (crate, modpath) in self.inline

    def file_of(self, crate, path, depth=0):
        """The module file that defines the item at absolute `path` (following imports)."""
        k = len(path)
        while k >= 0 and (crate, tuple(path[:k])) not in self.modules:
            k -= 1
        if k < 0:
            return None
        m = self.modules[(crate, tuple(path[:k]))]
        rest = path[k:]
        if not rest or depth > 8:
            return m
        name = rest[0]
        if (crate, tuple(path[: k + 1])) in self.inline or name in m.defined:
            return m
        for _, scope, segs, alias in m.uses:
            if scope != m.modpath or segs[-1] == "*":
                continue
            bound = alias or (segs[-2] if segs[-1] == "self" and len(segs) > 1 else segs[-1])
            if bound == name:
                target = self.absolute(m, scope, segs[:-1] if segs[-1] == "self" else segs)
                return m if target is None else self.file_of(crate, target + rest[1:], depth + 1)
        for _, scope, segs, alias in m.uses:
            if scope == m.modpath and segs[-1] == "*":
                target = self.absolute(m, scope, segs[:-1])
                if target is not None:
                    found = self.file_of(crate, target + rest, depth + 1)
                    if found is not None and name in found.defined:
                        return found
        return m


def folder_of(m):
    """The folder whose file graph `m` belongs to as a sibling."""
    return os.path.dirname(m.file)


def edges(modules):
    """(folder, from file, to file) → [(line, text)] for imports between files of one folder."""
    res = Resolver(modules)
    out = {}
    for m in modules.values():
        refs = [(pos, scope, segs, "use ") for pos, scope, segs, _ in m.uses]
        refs += [(pos, scope, segs, "") for pos, scope, segs in m.paths]
        for pos, scope, segs, kind in refs:
            path = res.absolute(m, scope, [s for s in segs if s != "*"] if segs[-1] == "*" else segs)
            if path is None:
                continue
            if segs[-1] == "self":
                path = path[:-1]
            t = res.file_of(m.crate, path)
            if t is None or t.file == m.file:
                continue
            if t.modpath[: len(m.modpath)] == m.modpath:
                continue  # the own module's import from its child
            if m.modpath[: len(t.modpath)] == t.modpath:
                if len(t.modpath) != len(m.modpath) - 1:
                    continue  # `super::super::…`: another folder's file
                folder = t.own_dir  # a child's import from its own module
            elif t.modpath[:-1] == m.modpath[:-1] and folder_of(t) == folder_of(m):
                folder = folder_of(m)
            else:
                continue
            text = kind + "::".join(segs)
            out.setdefault((folder, m.file, t.file), []).append((m.line(pos), text))
    return out


def cycles(graph):
    """Every elementary cycle of a small directed graph, each once, from its least node."""
    found = []
    nodes = sorted(graph)
    for s in nodes:
        stack = [(s, [s])]
        while stack:
            v, path = stack.pop()
            for w in sorted(graph.get(v, ()), reverse=True):
                if w == s:
                    found.append(path + [s])
                elif w > s and w not in path:
                    stack.append((w, path + [w]))
    return sorted(found, key=lambda c: (len(c), c))


def main():
    root = sys.argv[1] if len(sys.argv) > 1 else os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
    modules = load_all(root)
    by_folder = {}
    for (folder, a, b), where in edges(modules).items():
        by_folder.setdefault(folder, {}).setdefault(a, {})[b] = where
    total, groups = 0, []
    for folder in sorted(by_folder):
        graph = by_folder[folder]
        found = cycles({a: set(bs) for a, bs in graph.items()})
        for c in found:
            total += 1
            short = [os.path.relpath(f, folder) for f in c]
            print(f"{folder}/: {' → '.join(short)}")
            for a, b in zip(c, c[1:]):
                where = sorted(graph[a][b])
                more = f" (+{len(where) - 1} more)" if len(where) > 1 else ""
                print(f"    {os.path.relpath(a, folder)}:{where[0][0]}: {where[0][1]}{more}")
            # Cycles that share a file are one knot to untie.
            joined = set(c)
            for g in [g for g in groups if g & joined]:
                groups.remove(g)
                joined |= g
            groups.append(joined)
    print(f"{total} cycle{'s' if total != 1 else ''} in {len(groups)} group{'s' if len(groups) != 1 else ''} of files")
    return 1 if total else 0


if __name__ == "__main__":
    sys.exit(main())
