#!/usr/bin/env python3
"""Checks that no module of any crate imports a module that imports it, directly or through
others: for each `crates/*/src`, the module import graph (`use crate::...`, `use super::...`,
`crate::x::y` paths in code, `use child::...` of declared children; test modules and comments
left out; a path resolves to the deepest module file that exists), then its cycles. A module
declaring its children with `mod`, or re-exporting their items with `pub use`, does not import
them. Exits 1 and lists the cycles if there are
any. Usage: python3 scripts/module_cycles.py [WORKSPACE]"""
import os
import re
import sys


def crate_cycles(src):
    """The module import graph of one crate's src/ and its cycles (two-module and longer)."""
    mods = {}
    for root, _, files in os.walk(src):
        for f in files:
            if not f.endswith('.rs'): continue
            p = os.path.join(root, f)
            rel = os.path.relpath(p, src)[:-3].split(os.sep)
            if rel[-1] in ('mod',): rel = rel[:-1]
            if rel == ['lib'] or rel == ['main']: rel = []
            if rel and rel[0] == 'bin': continue
            mods[tuple(rel)] = p
    def resolve(parts):
        best = None
        for i in range(len(parts), -1, -1):
            if tuple(parts[:i]) in mods: return tuple(parts[:i])
        return ()
    edges = {}
    for m, p in mods.items():
        text = open(p).read()
        # drop test modules
        text = re.split(r'#\[cfg\(test\)\]\s*mod tests', text)[0]
        text = re.sub(r'//.*', '', text)
        # a re-export (`pub use child::X;`) makes a name public; it is not a use of it
        text = re.sub(r'^\s*pub(?:\([^)]*\))?\s+use\s[^;]*;', '', text, flags=re.M)
        out = set()
        for mt in re.finditer(r'\b(crate|super|self)((?:::\w+)+)', text):
            head, tail = mt.group(1), mt.group(2).split('::')[1:]
            if head == 'crate': base = []
            elif head == 'super':
                base = list(m[:-1]) if not p.endswith('mod.rs') and m else list(m[:-1])
                # super from a file module foo/bar.rs (m=(foo,bar)) is foo; from foo/mod.rs (m=(foo,)) is ()
            else: base = list(m)
            parts = base + tail
            # strip a trailing `{` group: handled by regex stopping at ::{
            t = resolve(parts)
            if t != m: out.add(t)
        # `use super::{a, b}` / `use crate::x::{a::B, c}` groups
        for mt in re.finditer(r'\b(crate|super)((?:::\w+)*)::\{([^}]*)\}', text):
            head = mt.group(1); tail = [x for x in mt.group(2).split('::') if x]
            base = [] if head == 'crate' else list(m[:-1])
            for item in mt.group(3).split(','):
                item = item.strip().split(' as ')[0]
                if not item or item == 'self': continue
                t = resolve(base + tail + item.split('::'))
                if t != m: out.add(t)
        # plain `use child::X` for declared children
        for mt in re.finditer(r'^\s*(?:pub(?:\([^)]*\))?\s+)?use\s+(\w+)::', text, re.M):
            name = mt.group(1)
            if name in ('crate', 'super', 'self', 'std', 'core', 'alloc'): continue
            if tuple(list(m) + [name]) in mods: out.add(tuple(list(m) + [name]))
        edges[m] = out
    name = lambda t: '::'.join(t) or 'crate'
    cycles = []
    for a in edges:
        for b in edges[a]:
            if a in edges.get(b, ()) and name(a) < name(b):
                cycles.append((name(a), name(b)))
    # longer cycles by DFS
    def find_cycles():
        found = set()
        def dfs(start, node, path):
            for n in edges.get(node, ()):
                if n == start and len(path) > 2:
                    found.add(tuple(sorted(name(x) for x in path)))
                elif n not in path and name(n) > name(start):
                    dfs(start, n, path + [n])
        for s in edges: dfs(s, s, [s])
        return found

    return cycles, find_cycles()


def main():
    root = sys.argv[1] if len(sys.argv) > 1 else os.path.join(os.path.dirname(__file__), "..")
    crates = os.path.join(root, "crates")
    bad = 0
    for c in sorted(os.listdir(crates)):
        src = os.path.join(crates, c, "src")
        if not os.path.isdir(src):
            continue
        two, longer = crate_cycles(src)
        for cyc in list(two) + sorted(longer):
            print(f"{c}: module cycle: {' <-> '.join(cyc)}")
            bad += 1
    print(f"module cycles: {bad}")
    return 1 if bad else 0


if __name__ == "__main__":
    sys.exit(main())
