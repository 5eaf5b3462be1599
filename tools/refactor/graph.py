"""The strongly connected components of an import graph (Tarjan), shared by module_graph.py and
file_graph.py: a component of more than one node is an import circle."""
import sys


def circles(nodes, edges):
    """Each component of more than one node among `nodes`, sorted; `edges` maps a node to its imports."""
    sys.setrecursionlimit(100000)
    index, low, stack, on, out, counter = {}, {}, [], set(), [], [0]

    def visit(v):
        index[v] = low[v] = counter[0]
        counter[0] += 1
        stack.append(v)
        on.add(v)
        for w in edges.get(v, ()):
            if w not in index:
                visit(w)
                low[v] = min(low[v], low[w])
            elif w in on:
                low[v] = min(low[v], index[w])
        if low[v] == index[v]:
            c = []
            while True:
                w = stack.pop()
                on.discard(w)
                c.append(w)
                if w == v:
                    break
            out.append(sorted(c))

    for v in nodes:
        if v not in index:
            visit(v)
    return [c for c in out if len(c) > 1]
