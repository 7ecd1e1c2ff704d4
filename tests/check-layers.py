#!/usr/bin/env python3
"""No import cycle between the files of a crate: every module depends only on layers below it.

Usage: check-layers.py SRC_DIR [SRC_DIR ...]   (each a crate's `src/`)

For every `.rs` file, the paths it names (`crate::a::b::Item`, `super::x`, `self::x`, in `use`
lines and inline) are resolved to the file that defines the module they end in (`a/b.rs` or
`a/b/mod.rs`, the longest prefix that exists). `mod x;` declarations are structure, not
dependencies; a file's own `#[cfg(test)] mod tests` and its `use super::*` are ignored. Prints
the file graph's cycles (strongly connected components) and exits 1 if there is one; else
prints each file's layer (0 = depends on nothing in the crate).
"""
import os
import re
import sys

path_re = re.compile(r"\b(crate|super|self)((?:::[A-Za-z_][A-Za-z0-9_]*)+|::\{)")


def module_of(src, f):
    rel = os.path.relpath(f, src)[:-3].split(os.sep)
    if rel[-1] in ("mod", "lib", "main"):
        rel = rel[:-1]
    return rel


def file_of(src, parts):
    """The file of the longest module prefix of `parts` that exists."""
    for n in range(len(parts), -1, -1):
        p = parts[:n]
        cands = [os.path.join(src, *p) + ".rs", os.path.join(src, *p, "mod.rs")] if p else [os.path.join(src, "lib.rs"), os.path.join(src, "main.rs")]
        for c in cands:
            if os.path.isfile(c):
                return c
    return None


def strip_tests(text):
    # Drop `#[cfg(test)] mod name { ... }` blocks (brace matched).
    out, i = [], 0
    for m in re.finditer(r"#\[cfg\(test\)\]\s*mod\s+\w+\s*\{", text):
        if m.start() < i:
            continue
        out.append(text[i:m.start()])
        depth, j = 1, m.end()
        while j < len(text) and depth:
            depth += {"{": 1, "}": -1}.get(text[j], 0)
            j += 1
        i = j
    out.append(text[i:])
    return "".join(out)


def expand_use_groups(text):
    """`use crate::a::{b, c::D}` -> the paths crate::a::b, crate::a::c::D (one level of braces)."""
    paths = []
    for m in re.finditer(r"\b(crate|super|self)((?:::\w+)*)::\{([^{}]*)\}", text):
        for item in m.group(3).split(","):
            item = item.strip().split(" as ")[0].strip()
            if item and item != "self" and item != "*":
                paths.append(m.group(1) + m.group(2) + "::" + item)
            else:
                paths.append(m.group(1) + m.group(2))
    return paths


def deps(src, f):
    text = strip_tests(open(f).read())
    text = re.sub(r"//[^\n]*", "", text)  # comments, doc comments
    me = module_of(src, f)
    paths = [m.group(0) for m in path_re.finditer(text) if not m.group(0).endswith("{")] + expand_use_groups(text)
    # A module's own children are named without a prefix (`drive_csv::load`).
    for child in re.findall(r"^\s*(?:pub(?:\([^)]*\))?\s+)?mod\s+(\w+)\s*;", text, re.M):
        if re.search(r"(?<![:\w])" + child + r"::", text):
            paths.append("self::" + child)
    out = set()
    for p in paths:
        parts = p.split("::")
        head, rest = parts[0], [x for x in parts[1:] if x]
        # `self` is this file's module, `super` its parent (for `a/mod.rs` the module is `a`).
        base = [] if head == "crate" else me if head == "self" else me[:-1]
        target = file_of(src, base + rest)
        if target and os.path.abspath(target) != os.path.abspath(f):
            out.add(os.path.abspath(target))
    return out


def sccs(graph):
    index, low, stack, on, res, n = {}, {}, [], set(), [], [0]

    def strong(v):
        index[v] = low[v] = n[0]
        n[0] += 1
        stack.append(v)
        on.add(v)
        for w in graph.get(v, ()):
            if w not in index:
                strong(w)
                low[v] = min(low[v], low[w])
            elif w in on:
                low[v] = min(low[v], index[w])
        if low[v] == index[v]:
            comp = []
            while True:
                w = stack.pop()
                on.discard(w)
                comp.append(w)
                if w == v:
                    break
            res.append(comp)

    sys.setrecursionlimit(10000)
    for v in graph:
        if v not in index:
            strong(v)
    return res


def main():
    bad = False
    for src in sys.argv[1:]:
        src = os.path.abspath(src)
        files = [os.path.join(d, x) for d, _, fs in os.walk(src) for x in fs if x.endswith(".rs")]
        graph = {f: deps(src, f) for f in files}
        cycles = [c for c in sccs(graph) if len(c) > 1]
        rel = lambda f: os.path.relpath(f, os.path.dirname(os.path.dirname(src)))
        if cycles:
            bad = True
            for c in cycles:
                print(f"import cycle in {rel(src)}: " + " <-> ".join(sorted(rel(f) for f in c)))
                for f in sorted(c):
                    print(f"    {rel(f)} uses " + ", ".join(sorted(rel(g) for g in graph[f] if g in c)))
            continue
        layer = {}

        def depth(f):
            if f not in layer:
                layer[f] = 0
                layer[f] = 1 + max((depth(g) for g in graph[f]), default=-1)
            return layer[f]

        for f in files:
            depth(f)
        print(f"{rel(src)}: {len(files)} files, no import cycle; layers:")
        for f in sorted(files, key=lambda f: (layer[f], f)):
            print(f"  {layer[f]:2}  {rel(f)}")
    sys.exit(1 if bad else 0)


main()
