#!/usr/bin/env python3
"""Circles between the files of one module in src/ (issue 54); prints nothing when there are none.
Run from the repository root: `python3 tools/refactor/file_graph.py`."""
import os, re, sys
root = "src"
files = {}
for dp, _, fs in os.walk(root):
    for f in fs:
        if f.endswith(".rs"):
            p = os.path.join(dp, f)
            rel = os.path.relpath(p, root)[:-3].split("/")
            if rel[-1] == "mod": rel = rel[:-1]
            files["::".join(rel)] = p
edges = {}
for mod, p in files.items():
    text = open(p).read().split("#[cfg(test)]")[0]
    text = "\n".join(l.split("//")[0] for l in text.splitlines())
    parent = mod.split("::")[:-1]
    deps = set()
    for m in re.finditer(r"(?<!\$)\b(crate|super|self)((?:::[a-z_0-9]+)+)", text):
        base, path = m.group(1), m.group(2).strip(":").split("::")
        if base == "crate": full = path
        elif base == "super": full = parent[:-0 or None] + path if True else None
        if base == "super":
            here = mod.split("::")
            # in a mod.rs file, super is the parent of this module; in x.rs, super is the parent too
            full = here[:-1] + path
        if base == "self":
            full = mod.split("::") + path
        # longest prefix that is a file module
        for k in range(len(full), 0, -1):
            cand = "::".join(full[:k])
            if cand in files:
                if cand != mod and not mod.startswith(cand + "::") :
                    deps.add(cand)
                break
    edges[mod] = deps
# cycles among siblings within the same parent
index, low, st, on, out, i = {}, {}, [], set(), [], [0]
sys.setrecursionlimit(100000)
def sc(v):
    index[v] = low[v] = i[0]; i[0] += 1; st.append(v); on.add(v)
    for w in edges.get(v, ()):
        if w not in index: sc(w); low[v] = min(low[v], low[w])
        elif w in on: low[v] = min(low[v], index[w])
    if low[v] == index[v]:
        c = []
        while True:
            w = st.pop(); on.discard(w); c.append(w)
            if w == v: break
        out.append(c)
for v in files:
    if v not in index: sc(v)
for c in out:
    if len(c) > 1: print(len(c), sorted(c))
