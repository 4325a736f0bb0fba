#!/usr/bin/env python3
"""Prints the data-flow picture of docs/architecture.md as Graphviz dot, read from the code:

- one node per public header of the core (core/include/picoscan/*.h); an arrow A -> B when B
  includes A, with arrows implied by a longer path left out (transitive reduction), so the
  picture reads in the direction data flows: patterns -> capture -> decode -> triangulate ...
- the pipeline node lists the recipes pipeline.h declares;
- the hosts (CLI, capture_qt, MeshLab plugin) with an arrow from each core header they include
  directly (again transitively reduced); the Python module, which binds every header, with one
  arrow from the core, and the FreeCAD workbench, which imports the module.

Usage: scripts/architecture_graph.py [REPOSITORY] | dot -Tsvg -o docs/images/architecture.svg
"""
import glob
import os
import re
import sys

INCLUDE = re.compile(r'^\s*#include\s+"picoscan/(\w+)\.h"', re.M)
# A declaration at namespace scope in pipeline.h: "Type name(" at the start of a line.
FUNCTION = re.compile(r"^[A-Za-z][\w:<>, ]*?[\w>]\s+(\w+)\(", re.M)


def read_text(path):
    with open(path, encoding="utf-8") as file:
        return file.read()


def includes(paths):
    found = set()
    for path in paths:
        found.update(INCLUDE.findall(read_text(path)))
    return found


def transitive_reduction(edges):
    """Drops A -> C when A -> ... -> C exists through other nodes."""
    successors = {}
    for a, b in edges:
        successors.setdefault(a, set()).add(b)

    def reachable(start, skip_edge):
        seen, stack = set(), [start]
        while stack:
            node = stack.pop()
            for following in successors.get(node, ()):
                if (node, following) == skip_edge or following in seen:
                    continue
                seen.add(following)
                stack.append(following)
        return seen

    return sorted((a, b) for a, b in edges if b not in reachable(a, (a, b)))


def main():
    root = os.path.abspath(sys.argv[1] if len(sys.argv) > 1 else os.path.join(os.path.dirname(__file__), os.pardir))
    include_dir = os.path.join(root, "core", "include", "picoscan")
    headers = sorted(os.path.basename(p)[:-2] for p in glob.glob(os.path.join(include_dir, "*.h")))
    # error.h and progress.h are included nearly everywhere: they would only add noise.
    shown = [h for h in headers if h not in ("error", "progress")]
    edges = set()
    for header in shown:
        for included in includes([os.path.join(include_dir, header + ".h")]):
            if included in shown and included != header:
                edges.add((included, header))

    pipeline_text = read_text(os.path.join(include_dir, "pipeline.h"))
    recipes = sorted(set(FUNCTION.findall(pipeline_text)) - {"validate"}) + ["validate"]

    def files(pattern):
        return sorted(glob.glob(os.path.join(root, pattern), recursive=True))

    hosts = {
        "cli": ("picoscan CLI\\ncore/cli/", files("core/cli/*.[ch]*")),
        "capture_qt": ("capture_qt (Qt 5)\\nprojector window, screen camera", files("capture_qt/**/*.[ch]*")),
        "meshlab": ("MeshLab plugin\\nmeshlab_plugin/", files("meshlab_plugin/*.[ch]*")),
    }

    out = ["digraph picoscan {",
           '  rankdir=LR; nodesep=0.25; ranksep=0.5; compound=true;',
           '  node [shape=box, style="rounded,filled", fillcolor="#eef3fb", fontname="Helvetica", fontsize=11];',
           '  edge [color="#6b7b99", arrowsize=0.6];',
           '  subgraph cluster_core { label="picoscan_core: core/include/picoscan/*.h (arrow: included by)"; '
           'fontname="Helvetica"; color="#9aa8c4";']
    for header in shown:
        if header == "pipeline":
            label = "pipeline.h\\n" + "\\n".join(name + "()" for name in recipes)
            out.append(f'    pipeline [label="{label}", fillcolor="#fde9c8"];')
        else:
            out.append(f'    {header} [label="{header}.h"];')
    out.append("  }")
    for a, b in transitive_reduction(edges):
        out.append(f"  {a} -> {b};")

    host_edges = set()
    for host, (label, paths) in hosts.items():
        out.append(f'  {host} [label="{label}", fillcolor="#e3f1e0"];')
        used = {h for h in includes(paths) if h in shown}
        # Only the headers not already reached through another one the host includes.
        for header in used:
            host_edges.add((header, host))
    reduced = transitive_reduction(edges | host_edges)
    for a, b in reduced:
        if b in hosts:
            out.append(f"  {a} -> {b} [color=\"#4f8a46\"];")
    # The Python module binds every header (one binding file each): one arrow from the cluster.
    out.append('  python [label="picoscan Python module\\ncore/python/: one file per header", fillcolor="#e3f1e0"];')
    out.append('  pipeline -> python [ltail=cluster_core, color="#4f8a46"];')
    out.append('  freecad [label="FreeCAD workbench\\nfreecad_workbench/", fillcolor="#e3f1e0"];')
    out.append('  python -> freecad [color="#4f8a46", label=" import picoscan", fontsize=9];')
    out.append('  capture_qt -> cli [color="#4f8a46"];')
    out.append("}")
    print("\n".join(out))


if __name__ == "__main__":
    main()
