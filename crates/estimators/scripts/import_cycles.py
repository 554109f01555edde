#!/usr/bin/env python3
"""Import graph of the crate's source files, and any cycle in it.

Every path that names a module of the crate counts as an edge from the file it is
written in to the file of the module it reaches: `crate::…`, `super::…`, `self::…` and
paths through a child module the file declares, in `use` lists (braces expanded) and in
code alike. Comments (doc links included) are not imports and are skipped; a `mod x;`
declaration makes x a child, not an import. Usage: import_cycles.py [SRC_DIR] [--edges]
"""

import os
import re
import sys

src = os.path.abspath(
    next((a for a in sys.argv[1:] if not a.startswith("--")), None)
    or os.path.join(os.path.dirname(__file__), "..", "src")
)

# Module path (tuple) -> file, for every .rs under src (lib.rs is the root; a.rs or
# a/mod.rs is module a).
modules = {}
for root, _, files in os.walk(src):
    for f in files:
        if not f.endswith(".rs"):
            continue
        rel = os.path.relpath(os.path.join(root, f), src)[:-3].split(os.sep)
        if rel == ["lib"]:
            key = ()
        elif rel[-1] == "mod":
            key = tuple(rel[:-1])
        else:
            key = tuple(rel)
        modules[key] = os.path.relpath(os.path.join(root, f), src)


def strip(text):
    """Code without comments, string and char literals (so that braces count)."""
    text = re.sub(r"/\*.*?\*/", " ", text, flags=re.S)
    text = re.sub(r'r#*"(?:.|\n)*?"#*', '""', text)
    text = re.sub(r'"(?:\\.|[^"\\])*"', '""', text)
    text = re.sub(r"'(?:\\.|[^'\\])'", "' '", text)
    return re.sub(r"//[^\n]*", "", text)


def expand(path):
    """`a::{b, c::{d, e}}` -> ["a::b", "a::c::d", "a::c::e"]."""
    path = re.sub(r"\s+", "", path)
    i = path.find("{")
    if i < 0:
        return [path]
    depth, parts, start = 0, [], i + 1
    for k in range(i, len(path)):
        ch = path[k]
        if ch == "{":
            depth += 1
        elif ch == "}":
            depth -= 1
            if depth == 0:
                parts.append(path[start:k])
                break
        elif ch == "," and depth == 1:
            parts.append(path[start:k])
            start = k + 1
    out = []
    for p in parts:
        if p:
            out += expand(path[:i] + p)
    return out


def resolve(base, segments):
    """The deepest module file reached by the path `segments` from module `base`."""
    segs = list(segments)
    cur = list(base)
    if segs[0] == "crate":
        cur, segs = [], segs[1:]
    while segs and segs[0] in ("super", "self"):
        if segs[0] == "super":
            cur = cur[:-1]
        segs = segs[1:]
    best = None
    for k in range(len(segs) + 1):
        key = tuple(cur + segs[:k])
        if key in modules:
            best = key
        elif k > 0:
            break
    return best


edges = {}
path_re = re.compile(r"(?<![\w:])((?:crate|super|self|[a-z_][a-z0-9_]*)(?:::(?:[A-Za-z_]\w*|\{[^;]*?\}|\*))+)")
for key, rel in sorted(modules.items(), key=lambda kv: kv[1]):
    code = strip(open(os.path.join(src, rel), encoding="utf-8").read())
    children = set(re.findall(r"\bmod\s+(\w+)\s*;", code))
    # Module path at each point: inline `mod name {` blocks nest below the file's module.
    stack, depth, mod_depths = list(key), 0, []
    pos = 0
    tokens = re.finditer(r"\bmod\s+(\w+)\s*\{|\{|\}|" + path_re.pattern, code)
    for m in tokens:
        t = m.group(0)
        if t.startswith("mod") and t.endswith("{"):
            depth += 1
            stack.append(m.group(1))
            mod_depths.append(depth)
            continue
        if t == "{":
            depth += 1
            continue
        if t == "}":
            if mod_depths and mod_depths[-1] == depth:
                mod_depths.pop()
                stack.pop()
            depth -= 1
            continue
        for p in expand(t):
            segs = p.split("::")
            inline = tuple(stack) != key
            if segs[0] not in ("crate", "super", "self") and not (
                segs[0] in children and not inline
            ):
                continue
            target = resolve(tuple(stack), segs)
            if target is None or target == key or (target in modules and modules[target] == rel):
                continue
            edges.setdefault(rel, set()).add(modules[target])

if "--edges" in sys.argv:
    for a in sorted(edges):
        for b in sorted(edges[a]):
            print(f"{a} -> {b}")

# Cycles: strongly connected components of more than one file (Tarjan).
index, low, on, stack, sccs, counter = {}, {}, set(), [], [], [0]


def visit(v):
    index[v] = low[v] = counter[0]
    counter[0] += 1
    stack.append(v)
    on.add(v)
    for w in sorted(edges.get(v, ())):
        if w not in index:
            visit(w)
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
        if len(comp) > 1:
            sccs.append(sorted(comp))


for v in sorted(modules.values()):
    if v not in index:
        visit(v)
n_edges = sum(len(v) for v in edges.values())
if sccs:
    for c in sccs:
        print("cycle:", " <-> ".join(c))
    sys.exit(1)
print(f"no import cycles: {len(modules)} files, {n_edges} edges")
