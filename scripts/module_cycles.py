#!/usr/bin/env python3
"""Finds import cycles between modules of the workspace's library crates.

A crate's modules are those its `src/lib.rs` declares, followed through `mod` declarations
(`foo.rs` and `foo/mod.rs` alike, `#[path]`, inline `mod x { ... }` blocks), `#[cfg(test)]`
items left out. Every path a module's code names is resolved to the module it lands in:
`crate::`, `self::`, `super::` (any number), `$crate::`, `use` trees with groups nested to any
depth, `pub use`, and bare `use child::...` / `use name::...` where `child` is a submodule or
`name` an import of the same module. A path through a name that its module imports from
elsewhere (`use` or `pub use`, not globs) is followed to where the name comes from, so
`super::Thing` re-exported by the parent from a sibling counts as using the sibling.

An edge between two modules counts between their ancestors that are siblings (children of the
lowest common ancestor), so a child using its parent's items is no cycle, but
`distrib -> cli -> distrib` is. Prints every cycle (strongly connected set of siblings) with
the lines that make it, and exits 1 if there is one.

    python3 scripts/module_cycles.py                    # every library crate of the workspace
    python3 scripts/module_cycles.py rem sunray         # some of them
    python3 scripts/module_cycles.py --root /other/tree # another checkout's crates
"""
import os
import re
import sys

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
import rust_source  # noqa: E402


_USE_RE = re.compile(r"(?<![\w$])use\s+([^;]*);")
_PATH_RE = re.compile(r"(?<![\w])(\$crate|crate|self|super)((?:\s*::\s*[A-Za-z_]\w*)+)")
_TOKEN_RE = re.compile(r"::|[{},*]|[A-Za-z_]\w*")


def use_tree_paths(tree):
    """The paths a `use` tree names: [(segments, alias)]; `*` and `self` kept as segments."""
    tokens = _TOKEN_RE.findall(tree)
    out = []

    def parse(i, prefix):
        path = list(prefix)
        if i < len(tokens) and tokens[i] == "::":
            path.append("::")
            i += 1
        while i < len(tokens):
            t = tokens[i]
            if t == "{":
                i += 1
                while i < len(tokens) and tokens[i] != "}":
                    i = parse(i, path)
                    if i < len(tokens) and tokens[i] == ",":
                        i += 1
                return i + 1
            if t == "*":
                out.append((path + ["*"], None))
                return i + 1
            if t in ("}", ","):
                return i
            path.append(t)
            i += 1
            if i < len(tokens) and tokens[i] == "::":
                i += 1
                continue
            alias = None
            if i + 1 < len(tokens) and tokens[i] == "as":
                alias = tokens[i + 1]
                i += 2
            out.append((path, alias))
            return i
        return i

    parse(0, [])
    return out


def _split(path_text):
    return [p.strip() for p in path_text.split("::") if p.strip()]


class Crate:
    """A crate's modules and the paths each names, resolved to absolute module paths."""

    def __init__(self, src_root, root_file="lib.rs"):
        self.src_root = src_root
        self.modules = rust_source.module_tree(os.path.join(src_root, root_file))
        # Per module: [(absolute path, offset)] of what it names; and {name: absolute path}
        # of what it imports (where a path through `module::name` really goes).
        self.refs = {}
        self.imports = {}
        for path, module in self.modules.items():
            self._read(path, module)

    def _resolve(self, segs, here, scope):
        """Absolute path tuple for `segs` named in module `here`, or None (another crate)."""
        if not segs:
            return None
        first = segs[0]
        if first in ("crate", "$crate"):
            return tuple(segs[1:])
        if first in ("self", "super"):
            base, rest = here, list(segs)
            while rest and rest[0] in ("self", "super"):
                if rest[0] == "super":
                    if not base:
                        return None
                    base = base[:-1]
                rest = rest[1:]
            return tuple(base) + tuple(rest)
        if first == "::":
            return None
        if first in self.modules[here].children:
            return tuple(here) + tuple(segs)
        if first in scope:
            return scope[first] + tuple(segs[1:])
        return None

    def _read(self, here, module):
        code = module.code
        refs = []
        imports = {}
        uses = []
        for m in _USE_RE.finditer(code):
            for segs, alias in use_tree_paths(m.group(1)):
                uses.append((segs, alias, m.start()))
        # Two passes: `use name::x` may go through a name another `use` brought in.
        for rooted_only in (True, False):
            for segs, alias, at in uses:
                rooted = segs[0] in ("crate", "$crate", "self", "super")
                if rooted != rooted_only:
                    continue
                abs_path = self._resolve(segs, here, imports)
                if abs_path is None:
                    continue
                glob = abs_path and abs_path[-1] == "*"
                while abs_path and abs_path[-1] in ("*", "self"):
                    abs_path = abs_path[:-1]
                refs.append((abs_path, at))
                if not glob and abs_path:
                    name = alias or (segs[-2] if segs[-1] == "self" else segs[-1])
                    if name != "_":
                        imports[name] = abs_path
        rest = _USE_RE.sub(lambda m: " " * len(m.group(0)), code)
        for m in _PATH_RE.finditer(rest):
            abs_path = self._resolve([m.group(1)] + _split(m.group(2)), here, imports)
            if abs_path is not None:
                refs.append((abs_path, m.start()))
        self.refs[here] = refs
        self.imports[here] = imports

    def target(self, path, seen=()):
        """The module an absolute path lands in, following imports of the names it goes through."""
        for k in range(len(path), -1, -1):
            mod = path[:k]
            if mod in self.modules:
                if k < len(path):
                    key = (mod, path[k])
                    via = self.imports.get(mod, {}).get(path[k])
                    if via is not None and key not in seen and via != path[: k + 1]:
                        return self.target(via + path[k + 1 :], seen + (key,))
                return mod
        return ()

    def sibling_edges(self):
        """{(from, to): (file, line)} between siblings, each with the first line that makes it."""
        edges = {}
        for here in sorted(self.modules):
            module = self.modules[here]
            for abs_path, at in self.refs[here]:
                best = self.target(abs_path)
                k = 0
                while k < min(len(here), len(best)) and here[k] == best[k]:
                    k += 1
                if k == len(here) or k == len(best):
                    continue  # the same module, an ancestor or a descendant
                edge = (here[: k + 1], best[: k + 1])
                if edge not in edges:
                    with open(module.file, encoding="utf-8") as f:
                        line = rust_source.line_of(f.read(), at)
                    edges[edge] = (module.file, line)
        return edges


def find_cycles(edges):
    """Strongly connected sets (more than one module) of the graph `edges`, each sorted."""
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
        for w in sorted(graph[v]):
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
    for v in sorted(graph):
        if v not in index:
            visit(v)
    return sorted(out)


def check(src_root):
    """(modules, edges, cycles) of the library crate whose sources lie in `src_root`."""
    crate = Crate(src_root)
    edges = crate.sibling_edges()
    return crate.modules, edges, find_cycles(edges)


def _name(path):
    return "::".join(path) or "crate"


def report(label, src_root, out=sys.stdout):
    """Prints the crate's verdict; returns how many cycles it has."""
    modules, edges, cycles = check(src_root)
    if not cycles:
        print(f"{label}: {len(modules)} modules, {len(edges)} sibling imports, no cycle", file=out)
    for comp in cycles:
        print(f"{label}: cycle among {', '.join(_name(c) for c in comp)}", file=out)
        for (a, b), (file, line) in sorted(edges.items()):
            if a in comp and b in comp:
                rel = os.path.relpath(file, os.path.dirname(os.path.dirname(src_root)))
                print(f"    {_name(a)} -> {_name(b)}  ({rel}:{line})", file=out)
    return len(cycles)


def main(argv):
    return rust_source.check_crates(argv, report)


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
