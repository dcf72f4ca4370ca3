#!/usr/bin/env python3
"""check_deps.py - the include graph of gpu/ and the call graph of the core's object files have no cycle.

Usage: scripts/check_deps.py [BUILD_DIR]
  includes: every '#include "x"' of gpu/**/*.{c,h,cu}, resolved by file name inside gpu/;
  calls:    with BUILD_DIR, 'nm' on the objects of the core library (BUILD_DIR/gpu/**/*.o): file A -> file B
            when A uses a symbol that B defines (function calls and data such as the feature table).
Prints each graph's edge count and every cycle (strongly connected set of files); exits 1 if there is one.
"""
import os
import re
import subprocess
import sys

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))


def cycles(graph):
    """Strongly connected components with more than one node, or a node with an edge to itself (Tarjan)."""
    index, low, stack, on, out = {}, {}, [], set(), []
    counter = [0]

    def visit(v):
        index[v] = low[v] = counter[0]
        counter[0] += 1
        stack.append(v)
        on.add(v)
        for w in sorted(graph.get(v, ())):
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
            if len(comp) > 1 or v in graph.get(v, ()):
                out.append(sorted(comp))

    sys.setrecursionlimit(10000)
    for v in sorted(graph):
        if v not in index:
            visit(v)
    return out


def include_graph():
    files = {}
    for d, _, names in os.walk(os.path.join(ROOT, "gpu")):
        for n in names:
            if n.endswith((".c", ".h", ".cu")):
                files.setdefault(n, os.path.relpath(os.path.join(d, n), ROOT))
    graph = {}
    for name, rel in files.items():
        with open(os.path.join(ROOT, rel), errors="replace") as f:
            incs = re.findall(r'^\s*#\s*include\s+"([^"]+)"', f.read(), re.M)
        graph[rel] = {files[os.path.basename(i)] for i in incs if os.path.basename(i) in files}
    return graph


def call_graph(build):
    objs = []
    for d, _, names in os.walk(os.path.join(build, "gpu")):
        objs += [os.path.join(d, n) for n in names if n.endswith(".o")]
    defined, used = {}, {}
    for o in objs:
        src = re.sub(r"^.*\.dir/", "gpu/", o)[:-2]
        res = subprocess.run(["nm", "-P", o], capture_output=True, text=True, check=True).stdout
        used[src] = set()
        for line in res.splitlines():
            parts = line.split()
            if len(parts) < 2:
                continue
            sym, kind = parts[0], parts[1]
            if kind == "U":
                used[src].add(sym)
            elif kind in "TDRBVWG" and kind != "w":
                defined.setdefault(sym, src)
    graph = {}
    for src, syms in used.items():
        graph[src] = {defined[s] for s in syms if s in defined and defined[s] != src}
    return graph


def report(title, graph):
    nedges = sum(len(v) for v in graph.values())
    cyc = cycles(graph)
    print("%s: %d files, %d edges, %d cycle(s)" % (title, len(graph), nedges, len(cyc)))
    for c in cyc:
        print("  cycle: " + " <-> ".join(c))
        for a in c:
            print("    %s -> %s" % (a, ", ".join(sorted(b for b in graph[a] if b in c))))
    return len(cyc)


def main():
    bad = report("includes (gpu/)", include_graph())
    if len(sys.argv) > 1:
        bad += report("calls (core objects)", call_graph(sys.argv[1]))
    return 1 if bad else 0


if __name__ == "__main__":
    sys.exit(main())
