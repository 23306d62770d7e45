"""Tests of code_shape.py: planted crates with long files and functions, and code that must
not count (tests, binaries, braces in strings and comments).

    python3 -m unittest discover -s scripts -p 'test_*.py'
"""
import io
import os
import sys
import tempfile
import unittest

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
import code_shape  # noqa: E402
from test_module_cycles import plant  # noqa: E402


def long_fn(name, body_lines, indent=""):
    """A function `body_lines + 2` lines long."""
    body = "".join(f"{indent}    let _x{i} = {i};\n" for i in range(body_lines))
    return f"{indent}fn {name}() {{\n{body}{indent}}}\n"


class Planted(unittest.TestCase):
    def shape(self, files):
        with plant(files) as src:
            found = code_shape.shape(src)
            return {
                "files": [(os.path.relpath(f, src), n) for f, n in found["files"]],
                "functions": [(name, n) for _, _, name, n in found["functions"]],
                "binary_functions": [(name, n) for _, _, name, n in found["binary_functions"]],
            }

    def test_long_function_found_short_one_not(self):
        found = self.shape({"lib.rs": "mod a;\n", "a.rs": long_fn("long", 99) + long_fn("short", 98)})
        self.assertEqual(found["functions"], [("a::long", 101)])
        self.assertEqual(found["files"], [])

    def test_methods_and_nested_dirs(self):
        body = long_fn("run", 120, indent="    ")
        found = self.shape(
            {
                "lib.rs": "pub mod daemon;\n",
                "daemon/mod.rs": "pub mod server;\n",
                "daemon/server.rs": f"pub struct S;\nimpl S {{\n{body}}}\n",
            }
        )
        self.assertEqual(found["functions"], [("daemon::server::run", 122)])

    def test_long_file(self):
        text = "".join(f"pub const C{i}: u32 = {i};\n" for i in range(501))
        found = self.shape({"lib.rs": "mod big;\nmod fine;\n", "big.rs": text, "fine.rs": text[:-30]})
        self.assertEqual(found["files"], [("big.rs", 501)])

    def test_tests_do_not_count(self):
        text = "".join(f"pub const C{i}: u32 = {i};\n" for i in range(450))
        tests = "#[cfg(test)]\nmod tests {\n" + long_fn("long_test", 200, indent="    ") + "}\n"
        found = self.shape(
            {
                "lib.rs": "mod a;\n#[cfg(test)]\nmod other_tests;\n",
                "a.rs": text + tests + "#[cfg(test)]\nmod tests_file;\n",
                "a/tests_file.rs": long_fn("in_test_file", 200),
                "other_tests.rs": long_fn("in_other_tests", 200),
            }
        )
        self.assertEqual(found, {"files": [], "functions": [], "binary_functions": []})

    def test_braces_in_strings_comments_and_chars(self):
        body = (
            "fn tricky() {\n"
            '    let _a = "}}}";\n'
            "    let _b = '}';\n"
            "    // }\n"
            "    /* } */\n"
            '    let _c = r#"}"#;\n'
            "    let _d: &'static str = \"\\\"}\";\n"
            + "".join(f"    let _x{i} = {i};\n" for i in range(100))
            + "}\n"
        )
        found = self.shape({"lib.rs": "mod a;\n", "a.rs": body})
        self.assertEqual(found["functions"], [("a::tricky", 108)])

    def test_declarations_without_body(self):
        found = self.shape(
            {
                "lib.rs": "mod a;\n",
                "a.rs": "pub trait T {\n    fn f(&self) -> [u8; 4];\n}\n" + long_fn("g", 99),
            }
        )
        self.assertEqual(found["functions"], [("a::g", 101)])

    def test_binaries_warn_only(self):
        found = self.shape(
            {
                "lib.rs": "pub mod a;\n",
                "a.rs": long_fn("fine", 10),
                "main.rs": "mod cli;\n" + long_fn("main", 150),
                "cli.rs": long_fn("parse", 120),
                "bin/tool.rs": long_fn("run", 130),
            }
        )
        self.assertEqual(found["functions"], [])
        self.assertEqual(
            sorted(found["binary_functions"]), [("main::cli::parse", 122), ("main::main", 152), ("tool::run", 132)]
        )
        with plant({"lib.rs": "", "main.rs": long_fn("main", 150)}) as src:
            self.assertEqual(code_shape.report("x", src, out=io.StringIO()), 0)

class CommandLine(unittest.TestCase):
    def test_a_crate_without_a_library_fails(self):
        """A wrong --root or crate name must not pass as "nothing found"."""
        import contextlib
        import rust_source
        with tempfile.TemporaryDirectory() as root:
            os.makedirs(os.path.join(root, "good", "src"))
            with open(os.path.join(root, "good", "src", "lib.rs"), "w", encoding="utf-8") as f:
                f.write("mod a;\n")
            with open(os.path.join(root, "good", "src", "a.rs"), "w", encoding="utf-8") as f:
                f.write("fn a() {}\n")
            with contextlib.redirect_stdout(io.StringIO()):
                self.assertEqual(rust_source.check_crates(["--root", root, "good"], lambda c, s: 0), 0)
                self.assertEqual(rust_source.check_crates(["--root", root, "gone"], lambda c, s: 0), 1)
                self.assertEqual(code_shape.main(["--root", root, "good"]), 0)
                self.assertEqual(code_shape.main(["--root", root, "good", "gone"]), 1)

if __name__ == "__main__":
    unittest.main()
