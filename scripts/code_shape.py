#!/usr/bin/env python3
"""Checks the size of the workspace's library code: files over 500 lines, functions over 100.

Library code is every module that a crate's `src/lib.rs` reaches through its `mod`
declarations (so `src/bin/`, `src/main.rs` and what only they declare are not library code),
less `#[cfg(test)]` items (test modules, in their own files or inline, and test helpers). A
file's length is its lines outside those items; a function's runs from the line of its `fn`
to its closing brace (comments, strings and char literals are not read for braces). Functions
of the binaries (`src/main.rs`, `src/bin/*`) over 100 lines are listed as a warning only.
Exits 1 if a library file or function is over its limit.

    python3 scripts/code_shape.py                    # every library crate of the workspace
    python3 scripts/code_shape.py rem sunray         # some of them
    python3 scripts/code_shape.py --root /other/tree # another checkout's crates
"""
import os
import re
import sys

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
import rust_source  # noqa: E402

MAX_FILE_LINES = 500
MAX_FN_LINES = 100

_FN_RE = re.compile(r"(?<![\w$])fn\s+([A-Za-z_]\w*)")


def functions(code):
    """(name, first line, last line) of every function with a body in cleaned `code`."""
    out = []
    for m in _FN_RE.finditer(code):
        end = rust_source.item_end(code, m.end())
        if code[end - 1] != "}":
            continue  # a declaration without a body
        out.append((m.group(1), rust_source.line_of(code, m.start()), rust_source.line_of(code, end - 1)))
    return out


def file_lines(file):
    """Lines of `file` outside its `#[cfg(test)]` items."""
    with open(file, encoding="utf-8") as f:
        raw = f.read()
    code = rust_source.clean(raw)
    lines = raw.count("\n") + (0 if raw.endswith("\n") or not raw else 1)
    for a, b in rust_source.test_item_spans(code):
        lines -= rust_source.line_of(code, max(a, b - 1)) - rust_source.line_of(code, a) + 1
    return lines


def _binary_roots(src_root):
    roots = [os.path.join(src_root, "main.rs")]
    bin_dir = os.path.join(src_root, "bin")
    if os.path.isdir(bin_dir):
        for name in sorted(os.listdir(bin_dir)):
            path = os.path.join(bin_dir, name)
            roots.append(os.path.join(path, "main.rs") if os.path.isdir(path) else path)
    return [r for r in roots if r.endswith(".rs") and os.path.isfile(r)]


def shape(src_root, max_file=MAX_FILE_LINES, max_fn=MAX_FN_LINES):
    """What is over the limits in the crate whose sources lie in `src_root`:
    {"files": [(file, lines)], "functions": [(file, line, name, lines)],
     "binary_functions": [(file, line, name, lines)]}."""
    library = rust_source.module_tree(os.path.join(src_root, "lib.rs"))
    lib_files = {os.path.normpath(m.file) for m in library.values()}
    out = {"files": [], "functions": [], "binary_functions": []}
    for file in sorted(lib_files):
        n = file_lines(file)
        if n > max_file:
            out["files"].append((file, n))

    def long_functions(modules, key, skip):
        seen = set()
        for path in sorted(modules):
            module = modules[path]
            if os.path.normpath(module.file) in skip:
                continue
            for name, first, last in functions(module.code):
                n = last - first + 1
                if n > max_fn and (module.file, first) not in seen:
                    seen.add((module.file, first))
                    qual = "::".join(path + (name,))
                    out[key].append((os.path.normpath(module.file), first, qual, n))

    long_functions(library, "functions", set())
    binaries = {}
    for root in _binary_roots(src_root):
        for path, module in rust_source.module_tree(root).items():
            stem = os.path.splitext(os.path.basename(root))[0]
            if stem == "main" and os.path.dirname(root) != src_root:
                stem = os.path.basename(os.path.dirname(root))
            binaries[(stem,) + path] = module
    long_functions(binaries, "binary_functions", lib_files)
    return out


def report(label, src_root, out=sys.stdout):
    """Prints what is over the limits; returns how many library items are."""
    found = shape(src_root)
    top = os.path.dirname(os.path.dirname(src_root))
    for file, n in found["files"]:
        print(f"{label}: {os.path.relpath(file, top)}: {n} lines (library files: at most {MAX_FILE_LINES})", file=out)
    for file, line, name, n in found["functions"]:
        print(f"{label}: {name} ({os.path.relpath(file, top)}:{line}): {n} lines"
              f" (library functions: at most {MAX_FN_LINES})", file=out)
    for file, line, name, n in found["binary_functions"]:
        print(f"{label}: warning: binary function {name} ({os.path.relpath(file, top)}:{line}): {n} lines"
              f" (over {MAX_FN_LINES})", file=out)
    bad = len(found["files"]) + len(found["functions"])
    if not bad:
        print(f"{label}: no library file over {MAX_FILE_LINES} lines, no library function over {MAX_FN_LINES}",
              file=out)
    return bad


def main(argv):
    return rust_source.check_crates(argv, report)


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
