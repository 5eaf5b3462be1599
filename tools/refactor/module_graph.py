#!/usr/bin/env python3
"""Import graph of src/ (issue 54): circles between top-level modules, the edges of each, and the
imports that run back up the spec order (the last two lines). Run from the repository root:
`python3 tools/refactor/module_graph.py`."""
import os, re, sys
sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from graph import circles  # noqa: E402
root = "src"
edges = {}
def modname(path):
    rel = os.path.relpath(path, root)[:-3]
    parts = rel.split("/")
    if parts[-1] in ("mod", "lib"): parts = parts[:-1]
    return parts[0] if parts else "lib"
for dp, _, fs in os.walk(root):
    for f in fs:
        if not f.endswith(".rs"): continue
        p = os.path.join(dp, f)
        m = modname(p)
        text = "\n".join(l.split("//")[0] for l in open(p).read().splitlines())
        text = re.sub(r"#\[cfg\(test\)\]\s*mod tests\s*\{.*", "", text, flags=re.S)
        for t in re.findall(r"(?<!\$)crate::([a-z_]+)", text):
            if t != m and t not in ("Result", "Error"):
                edges.setdefault(m, set()).add(t)
        if re.search(r"(?<!\$)crate::(Result|Error)\b", text) and m not in ("error", "lib", "prelude"):
            edges.setdefault(m, set()).add("error")
mods = sorted(set(edges) | {t for v in edges.values() for t in v})
for c in circles(mods, edges):
    print("cycle:", c)
for m in sorted(edges):
    print(m, "->", sorted(edges[m]))
level = {}
for i, grp in enumerate([["choice","codes","error","fsutil","raster","colour"],["mapping","continuity"],["layer","resample"],["layer_io","pack","manifest","image_io"],["panorama","input"],["prepare","layering","mesh","render","validate","scene","viewer"],["jobs"],["prelude","lib"]]):
    for m in grp: level[m] = i
up = [(a,b) for a in edges for b in edges[a] if level.get(b,0) > level.get(a,0)]
same = [(a,b) for a in edges for b in edges[a] if level.get(b,0) == level.get(a,0) and a != b]
print("back up:", up)
print("same level:", sorted(same))
