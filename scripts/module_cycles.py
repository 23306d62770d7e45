#!/usr/bin/env python3
"""Finds import cycles between modules of the workspace's library crates.

A file's module path comes from where it lies under `src/` (`src/distrib/controller/mod.rs`
is `distrib::controller`). Every `crate::a::b::...` path in code (comments and `#[cfg(test)]
mod tests` blocks left out, `tests.rs` files skipped) is an edge from that file's module to the
longest module prefix of the path; `super::` paths are resolved the same way. An edge between
two modules counts between their ancestors that are siblings (children of the lowest common
ancestor), so a child using its parent's items is no cycle, but `distrib -> cli -> distrib` is.
Prints every cycle (strongly connected set of siblings) and exits 1 if there is one.

    python3 scripts/module_cycles.py            # every library crate of the workspace
    python3 scripts/module_cycles.py rem sunray # some of them
"""
import os
import re
import sys

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
CRATES = ["yari", "sunray", "rem", "modeler-cli"]
PATH_RE = re.compile(r"\b(crate|super)((?:::\s*[A-Za-z_][A-Za-z0-9_]*)+)")
USE_GROUP_RE = re.compile(r"\buse\s+(crate|super)((?:::[A-Za-z_][A-Za-z0-9_]*)*)::\{([^;]*)\}\s*;", re.S)


def module_of(rel):
    """src-relative file path -> module path tuple."""
    parts = rel[:-3].split(os.sep)
    if parts[-1] in ("mod", "lib"):
        parts = parts[:-1]
    return tuple(parts)


def strip(text):
    text = re.sub(r"/\*.*?\*/", "", text, flags=re.S)
    out = []
    for line in text.splitlines():
        if re.match(r"\s*#\[cfg\(test\)\]", line):
            break  # test modules sit at a file's end by our convention
        out.append(re.sub(r"//.*", "", line))
    return "\n".join(out)


def targets(text, here):
    """Module-path prefixes (unresolved) that the file refers to."""
    found = []
    for m in USE_GROUP_RE.finditer(text):
        base = [p for p in m.group(2).split("::") if p]
        for item in re.split(r",", m.group(3)):
            name = item.strip().split("::")[0].split(" ")[0].strip("{} \n")
            if name and name != "self":
                found.append((m.group(1), base + [name] + [p for p in item.strip().split("::")[1:] if p]))
            elif name == "self":
                found.append((m.group(1), base))
    text = USE_GROUP_RE.sub("", text)
    for m in PATH_RE.finditer(text):
        found.append((m.group(1), [p.strip() for p in m.group(2).split("::") if p.strip()]))
    out = []
    for root, path in found:
        if root == "crate":
            out.append(tuple(path))
        else:
            base = list(here)
            while path and path[0] == "super":
                path = path[1:]
                base = base[:-1]
            out.append(tuple(base[:-1] + path))
    return out


def crate_graph(crate):
    src = os.path.join(ROOT, crate, "src")
    files = {}
    for dirpath, _, names in os.walk(src):
        if os.path.join(src, "bin") in dirpath:
            continue
        for n in names:
            if not n.endswith(".rs") or n == "tests.rs" or n == "main.rs":
                continue
            rel = os.path.relpath(os.path.join(dirpath, n), src)
            files[module_of(rel)] = os.path.join(dirpath, n)
    modules = set(files)
    edges = set()
    for mod, path in files.items():
        with open(path, encoding="utf-8") as f:
            text = strip(f.read())
        # `super` inside a file is relative to the file's module: `super::x` of a::b is a::x.
        for target in targets(text, mod + ("_",)):
            best = None
            for k in range(len(target), 0, -1):
                if target[:k] in modules:
                    best = target[:k]
                    break
            if best is None or best == mod:
                continue
            # Lift to the children of the lowest common ancestor.
            k = 0
            while k < min(len(mod), len(best)) and mod[k] == best[k]:
                k += 1
            if k == len(mod) or k == len(best):
                continue  # ancestor / descendant
            edges.add((mod[: k + 1], best[: k + 1]))
    return modules, edges


def cycles(edges):
    graph = {}
    for a, b in edges:
        graph.setdefault(a, set()).add(b)
        graph.setdefault(b, set())
    index, low, stack, on, out = {}, {}, [], set(), []
    counter = [0]

    def visit(v):
        index[v] = low[v] = counter[0]
        counter[0] += 1
        stack.append(v)
        on.add(v)
        for w in graph[v]:
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
                out.append(sorted(comp))

    sys.setrecursionlimit(10000)
    for v in list(graph):
        if v not in index:
            visit(v)
    return out, graph


def main():
    crates = sys.argv[1:] or CRATES
    bad = 0
    for crate in crates:
        modules, edges = crate_graph(crate)
        found, graph = cycles(edges)
        if not found:
            print(f"{crate}: {len(modules)} modules, {len(edges)} sibling imports, no cycle")
        for comp in found:
            bad += 1
            names = ["::".join(c) for c in comp]
            print(f"{crate}: cycle among {', '.join(names)}")
            for a in comp:
                for b in sorted(graph[a]):
                    if b in comp:
                        print(f"    {'::'.join(a)} -> {'::'.join(b)}")
    sys.exit(1 if bad else 0)


if __name__ == "__main__":
    main()
