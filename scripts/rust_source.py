"""Reading Rust source well enough for the shape checks (module_cycles.py, code_shape.py).

Not a parser: comments and literals are blanked (same length, newlines kept, so offsets and
line numbers still hold), braces are matched on what is left, and a crate's module tree is
walked from its root file by its `mod` declarations, `#[path]` and inline `mod x { ... }`
blocks included, `#[cfg(test)]` items left out.
"""
import os
import re

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
CRATES = ["yari", "sunray", "rem", "modeler-cli"]

_CHAR_RE = re.compile(r"'(?:\\u\{[0-9a-fA-F]+\}|\\x[0-9a-fA-F]{2}|\\.|[^\\'\n])'")
_RAW_RE = re.compile(r'(?:b|c)?r(#*)"')
_TEST_ATTR_RE = re.compile(r"#\[cfg\((?:test|all\(test\b[^\]]*)\)\]")
_MOD_RE = re.compile(
    r"(?P<attrs>(?:#\[[^\]]*\]\s*)*)(?:pub(?:\s*\([^)]*\))?\s+)?\bmod\s+(?P<name>[A-Za-z_]\w*)\s*(?P<end>[;{])"
)
_PATH_ATTR_RE = re.compile(r'#\[\s*path\s*=\s*"([^"]*)"\s*\]')


def _blank(chars, start, end):
    for i in range(start, end):
        if chars[i] != "\n":
            chars[i] = " "


def _ident_char(c):
    return c.isalnum() or c == "_"


def clean(text):
    """`text` with comments blanked and string/char literals' contents blanked."""
    chars = list(text)
    i, n = 0, len(text)
    while i < n:
        c = text[i]
        if text.startswith("//", i):
            j = text.find("\n", i)
            j = n if j < 0 else j
            _blank(chars, i, j)
            i = j
        elif text.startswith("/*", i):
            depth, j = 1, i + 2
            while j < n and depth:
                if text.startswith("/*", j):
                    depth, j = depth + 1, j + 2
                elif text.startswith("*/", j):
                    depth, j = depth - 1, j + 2
                else:
                    j += 1
            _blank(chars, i, j)
            i = j
        elif c in "rbc" and (i == 0 or not _ident_char(text[i - 1])) and _RAW_RE.match(text, i):
            m = _RAW_RE.match(text, i)
            close = '"' + m.group(1)
            j = text.find(close, m.end())
            j = n if j < 0 else j
            _blank(chars, m.end(), j)
            i = j + len(close)
        elif c == '"':
            j = i + 1
            while j < n and text[j] != '"':
                j += 2 if text[j] == "\\" else 1
            _blank(chars, i + 1, min(j, n))
            i = j + 1
        elif c == "'":
            m = _CHAR_RE.match(text, i)
            if m:
                _blank(chars, i + 1, m.end() - 1)
                i = m.end()
            else:
                i += 1  # a lifetime or label
        else:
            i += 1
    return "".join(chars)


def matching_brace(text, open_at):
    """Index of the `}` closing the `{` at `open_at` in cleaned text (len(text) if none)."""
    depth = 0
    for i in range(open_at, len(text)):
        c = text[i]
        if c == "{":
            depth += 1
        elif c == "}":
            depth -= 1
            if depth == 0:
                return i
    return len(text)


def item_end(text, start):
    """End (exclusive) of the item starting at `start`: its `;` or its closing brace."""
    depth = 0
    for i in range(start, len(text)):
        c = text[i]
        if c in "([{":
            depth += 1
        elif c in ")]}":
            depth -= 1
            if depth == 0 and c == "}":
                return i + 1
        elif c == ";" and depth == 0:
            return i + 1
    return len(text)


def test_item_spans(text):
    """(start, end) of every `#[cfg(test)]` item (attribute included) in cleaned text."""
    spans = []
    pos = 0
    while True:
        m = _TEST_ATTR_RE.search(text, pos)
        if not m:
            return spans
        end = item_end(text, m.end())
        spans.append((m.start(), end))
        pos = end


def blank_spans(text, spans):
    chars = list(text)
    for a, b in spans:
        _blank(chars, a, b)
    return "".join(chars)


def line_of(text, offset):
    return text.count("\n", 0, offset) + 1


class Module:
    """One module of a crate: where it is, and its own code (cleaned, test items and inline
    submodules blanked, offsets those of its file)."""

    def __init__(self, path, file, code, children):
        self.path = path  # tuple of names, () for the crate root
        self.file = file
        self.code = code
        self.children = children  # names of its submodules


def module_tree(root_file):
    """Every non-test module reachable from a crate root file: {path tuple: Module}."""
    modules = {}
    _load_file(modules, (), root_file, mod_rs=True)
    return modules


def _load_file(modules, path, file, mod_rs):
    if path in modules or not os.path.isfile(file):
        return
    with open(file, encoding="utf-8") as f:
        raw = f.read()
    code = clean(raw)
    code = blank_spans(code, test_item_spans(code))
    stem = os.path.splitext(os.path.basename(file))[0]
    here = os.path.dirname(file)
    child_dir = here if mod_rs else os.path.join(here, stem)
    _load_region(modules, path, file, raw, code, 0, len(code), here, child_dir)


def _load_region(modules, path, file, raw, code, start, end, file_dir, child_dir):
    """The module `path` whose code is code[start:end]; its file submodules lie in child_dir."""
    own = list(code)
    _blank(own, 0, start)
    _blank(own, end, len(code))
    children = []
    modules[path] = None  # claimed
    pos = start
    while True:
        m = _MOD_RE.search(code, pos, end)
        if not m:
            break
        name = m.group("name")
        children.append(name)
        sub = path + (name,)
        attr = _PATH_ATTR_RE.search(raw, m.start("attrs"), m.end("attrs")) if m.group("attrs") else None
        if m.group("end") == "{":
            close = matching_brace(code, m.end() - 1)
            _blank(own, m.end(), close)
            sub_dir = os.path.join(child_dir, name)
            if attr:
                sub_dir = os.path.join(child_dir, attr.group(1))
            _load_region(modules, sub, file, raw, code, m.end(), close, file_dir, sub_dir)
            pos = close + 1
        else:
            if attr:
                # A `#[path]` file is relative to the declaring file's directory (to the
                # module's directory inside an inline block) and owns its directory.
                base = file_dir if start == 0 else child_dir
                _load_file(modules, sub, os.path.normpath(os.path.join(base, attr.group(1))), True)
            else:
                flat = os.path.join(child_dir, name + ".rs")
                nested = os.path.join(child_dir, name, "mod.rs")
                if os.path.isfile(flat):
                    _load_file(modules, sub, flat, False)
                else:
                    _load_file(modules, sub, nested, True)
            pos = m.end()
    modules[path] = Module(path, file, "".join(own), children)


def check_crates(argv, report):
    """A check's command line: `[--root DIR] [CRATE ...]` (default: this checkout and every
    library crate); runs `report(crate, src_dir)` for each crate, which returns how many faults
    it printed. Returns the exit status: 1 if there was any."""
    root = ROOT
    if argv[:1] == ["--root"]:
        root, argv = argv[1], argv[2:]
    bad = 0
    for crate in argv or CRATES:
        src = os.path.join(root, crate, "src")
        if not os.path.isfile(os.path.join(src, "lib.rs")):
            print(f"{crate}: no library here ({src}/lib.rs is missing)")
            bad += 1
            continue
        bad += report(crate, src)
    return 1 if bad else 0
