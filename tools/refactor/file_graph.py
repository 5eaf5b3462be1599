#!/usr/bin/env python3
"""Circles between the files of one module in src/ (issue 54); prints nothing when there are none.
Run from the repository root: `python3 tools/refactor/file_graph.py`."""
import os, re, sys
sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from graph import circles  # noqa: E402
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
        # super is the parent module, in a mod.rs file as in x.rs
        full = {"crate": path, "super": parent + path, "self": mod.split("::") + path}[base]
        # longest prefix that is a file module
        for k in range(len(full), 0, -1):
            cand = "::".join(full[:k])
            if cand in files:
                if cand != mod and not mod.startswith(cand + "::") :
                    deps.add(cand)
                break
    edges[mod] = deps
for c in circles(files, edges):
    print(len(c), c)
