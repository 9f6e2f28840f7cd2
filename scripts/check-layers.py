#!/usr/bin/env python3
"""Check that hfrt's top-level source folders include each other only downwards.

Every quoted `#include "..."` (and `#include <hfrt/...>`, jit's public headers) in a
tracked C/C++ source is mapped to the top-level folder the header lives in.  The
resulting folder graph is printed with counts; the script exits 1 if an edge is not
allowed by LAYERS below, if the folder graph has a cycle, or if a folder holding
C/C++ sources is missing from LAYERS.  Otherwise it prints "layers: ok (...)" and
exits 0.

    scripts/check-layers.py          # edge list + verdict
    scripts/check-layers.py --dot    # Graphviz dot on stdout (verdict on stderr)
"""
import argparse
import os
import posixpath
import re
import subprocess
import sys
from collections import defaultdict

# Allowed dependencies, lowest layer first.  A folder may always include itself.
# "*" allows any folder; "!name" then forbids one folder again.
LIBS = ["base", "gpu", "lang", "ir", "stdlib", "geom", "jit", "render", "scene", "mesher", "app", "cluster"]
LAYERS = {
    "base": set(),                                      # checks, Result, files, Vec3/Box/Interval, timers
    "gpu": {"base"},                                    # CUDA driver loaded at run time, kernel ABI
    "lang": {"base"},                                   # HyperFun lexer, parser, sema
    "ir": {"lang", "base"},                             # intermediate representation
    "stdlib": {"ir", "lang", "base", "geom"},           # HyperFun library functions
    "geom": {"base"},                                   # meshes, BVH, patches
    "jit": {"stdlib", "ir", "lang", "base", "geom", "gpu"},    # lowering, interpreters, LLVM; owns hfrt/*.h
    "render": {"base"},                                 # ray tracer, knows fields not models
    "scene": {"render", "base"},                        # scene files (TOML) into SceneDescs
    "mesher": {"render", "base"},                       # dual contouring of a render::Field; mesh files
    "app": {"jit", "render", "scene", "mesher", "geom", "stdlib", "ir", "lang", "base", "gpu"},  # joins models and renderer
    "cluster": {"app", "render", "scene", "base"},      # MPI: renders across processes
    "testsupport": set(LIBS),                           # test helpers shared by tests/ and bench/
    "tools": set(LIBS),                                 # the hfrt command-line tool
    "tests": {"*"},                                     # top: anything
    "bench": {"*", "!tests"},                           # top, but not the test tree
    "examples": {"*"},                                  # top: anything
    "fuzz": {"*"},                                      # top: anything
    # hfrt as a library (issue 19): above app/, beside tools/.
    "capi": {"app", "jit", "render", "scene", "geom", "stdlib", "ir", "lang", "base"},  # libhfrt.so: C API
    "python": {"capi", "jit"},                          # the Python module: public headers only
}
PUBLIC_DIRS = {"hfrt": "jit"}   # `hfrt/x.h` resolves to jit/include/hfrt/x.h
SEARCH_ROOTS = ["", "jit/include", "capi/include"]  # -I paths, relative to the repo root
EXTS = (".h", ".hpp", ".cpp", ".cc", ".c")
INCLUDE_RE = re.compile(r'^\s*#\s*include\s*([<"])([^">]+)[">]')


def source_files(root):
    """Tracked C/C++ sources (repo-relative, '/'-separated); os.walk without git."""
    try:
        out = subprocess.run(["git", "-C", root, "ls-files", "-z"], check=True,
                             capture_output=True, text=True).stdout
        files = out.split("\0")
    except (OSError, subprocess.CalledProcessError):
        files = []
        for d, dirs, names in os.walk(root):
            dirs[:] = [x for x in dirs if not x.startswith((".", "build"))]
            files += [os.path.relpath(os.path.join(d, n), root).replace(os.sep, "/") for n in names]
    return sorted(f for f in files if f.endswith(EXTS))


def folder_of(path):
    return path.split("/", 1)[0] if "/" in path else "(root)"


def resolve(src, inc, quoted, known):
    """Folder of the header `inc` included from `src`, or None for system headers."""
    first = inc.split("/", 1)[0]
    if not quoted:  # <...> is a system header, except jit's public <hfrt/...>
        return PUBLIC_DIRS.get(first) if "/" in inc else None
    # Like the compiler: the including file's directory first, then the -I roots.
    for base in [posixpath.dirname(src)] + SEARCH_ROOTS:
        cand = posixpath.normpath(posixpath.join(base, inc))
        if cand in known:
            return folder_of(cand)
    if "/" not in inc:  # unknown bare header: assume it sits next to the includer
        return folder_of(src)
    return PUBLIC_DIRS.get(first, first)


def allowed(frm, to):
    rule = LAYERS.get(frm)
    if frm == to or rule is None:  # unknown folders are reported separately
        return True
    return f"!{to}" not in rule and ("*" in rule or to in rule)


def cycles(nodes, succ):
    """Strongly connected components with more than one folder (Tarjan)."""
    index, low, stack, on, out = {}, {}, [], set(), []

    def visit(v):
        index[v] = low[v] = len(index)
        stack.append(v)
        on.add(v)
        for w in succ(v):
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
                out.append(comp)

    for v in nodes:
        if v not in index:
            visit(v)
    return out


def order_key(folder):
    names = list(LAYERS)
    return (names.index(folder), "") if folder in LAYERS else (len(names), folder)


def edge_key(item):
    (frm, to), _ = item
    return order_key(frm), order_key(to)


def describe(rule):
    """Human-readable allowed set, e.g. "anything but tests"."""
    if "*" in rule:
        return "anything" + "".join(f" but {d[1:]}" for d in sorted(rule) if d.startswith("!"))
    return ", ".join(sorted(rule, key=order_key)) or "nothing"


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--dot", action="store_true", help="print Graphviz dot of the folder graph")
    ap.add_argument("--root", help="the tree to check (default: this repository)")
    args = ap.parse_args()
    root = os.path.abspath(args.root) if args.root else \
        os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
    report = sys.stderr if args.dot else sys.stdout

    files = source_files(root)
    known = set(files)
    edges = defaultdict(list)  # (from, to) -> ["file:line: #include ...", ...]
    for src in files:
        try:
            with open(os.path.join(root, src), encoding="utf-8", errors="replace") as fh:
                lines = fh.readlines()
        except OSError:
            continue  # tracked but deleted in the work tree
        for no, line in enumerate(lines, 1):
            m = INCLUDE_RE.match(line)
            to = m and resolve(src, m.group(2), m.group(1) == '"', known)
            if to:
                edges[folder_of(src), to].append(f"{src}:{no}: {line.strip()}")

    # Cross-folder graph (self-edges are always fine and left out of it).
    graph = {e: locs for e, locs in edges.items() if e[0] != e[1]}
    folders = sorted({f for e in edges for f in e} | {folder_of(f) for f in files}, key=order_key)
    bad = {e: locs for e, locs in graph.items() if not allowed(*e)}
    succ = lambda v: sorted((t for (f, t) in graph if f == v), key=order_key)
    loops = cycles(folders, succ)
    unknown = [f for f in folders if f not in LAYERS]
    # The table itself must be a DAG, or "up" would be meaningless.
    table_loops = cycles(list(LAYERS), lambda v: sorted(d for d in LAYERS[v] if d in LAYERS))

    if args.dot:
        print("digraph layers {\n  rankdir=BT;\n  node [shape=box];")
        for f in folders:
            print(f'  "{f}"' + (" [style=dashed]" if f in unknown else "") + ";")
        for (f, t), locs in sorted(graph.items(), key=edge_key):
            colour = ', color=red, fontcolor=red' if (f, t) in bad else ""
            print(f'  "{f}" -> "{t}" [label="{len(locs)}"{colour}];')
        print("}")
    else:
        print("folder include graph (from -> to, include count; '.' same folder, '!!' not allowed):")
        for (f, t), locs in sorted(edges.items(), key=edge_key):
            mark = "!!" if (f, t) in bad else ("  " if f != t else " .")
            print(f"  {mark} {f:>12} -> {t:<12} {len(locs):5}")

    for comp in table_loops:
        print(f"error: LAYERS table has a cycle among: {', '.join(sorted(comp))}", file=report)
    for f in unknown:
        n = sum(folder_of(s) == f for s in files)
        print(f"error: unknown folder '{f}' ({n} C/C++ sources): add it to LAYERS", file=report)
    for (f, t), locs in sorted(bad.items(), key=edge_key):
        print(f"error: {f}/ may not include {t}/ ({len(locs)} includes; allowed: "
              f"{describe(LAYERS[f])}):", file=report)
        for loc in locs:
            print(f"    {loc}", file=report)
    for comp in loops:
        comp = sorted(comp, key=order_key)
        print(f"error: folder cycle among {', '.join(comp)}:", file=report)
        for (f, t), locs in sorted(graph.items(), key=edge_key):
            if f in comp and t in comp:
                print(f"  {f} -> {t} ({len(locs)} includes), e.g. {locs[0]}", file=report)
    if table_loops or unknown or bad or loops:
        print(f"layers: FAILED ({len(bad)} disallowed edges, {len(loops)} cycles, "
              f"{len(unknown)} unknown folders)", file=report)
        return 1
    print(f"layers: ok ({len(files)} files, {len(graph)} edges)", file=report)
    return 0


if __name__ == "__main__":
    sys.exit(main())
