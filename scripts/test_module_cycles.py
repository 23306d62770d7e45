"""Tests of module_cycles.py: planted crates in temporary directories, each with a cycle the
check must find, or none that it must not invent.

    python3 -m unittest discover -s scripts -p 'test_*.py'
"""
import os
import sys
import tempfile
import textwrap
import unittest

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
import module_cycles  # noqa: E402


def plant(files):
    """A temporary crate source root holding `files` ({src-relative path: text})."""
    tmp = tempfile.TemporaryDirectory()
    for rel, text in files.items():
        path = os.path.join(tmp.name, rel)
        os.makedirs(os.path.dirname(path), exist_ok=True)
        with open(path, "w", encoding="utf-8") as f:
            f.write(textwrap.dedent(text))
    return tmp


class Planted(unittest.TestCase):
    def cycles(self, files):
        with plant(files) as src:
            _, _, found = module_cycles.check(src)
        return [["::".join(m) for m in comp] for comp in found]

    def assert_cycle(self, files, *members):
        self.assertEqual(self.cycles(files), [sorted(members)])

    def assert_no_cycle(self, files):
        self.assertEqual(self.cycles(files), [])

    def test_super_between_siblings(self):
        # The old script read `super::c` in a::b as a::b::c and found nothing.
        self.assert_cycle(
            {
                "lib.rs": "mod a;\n",
                "a/mod.rs": "mod b;\nmod c;\n",
                "a/b.rs": "use super::c::C;\npub struct B;\n",
                "a/c.rs": "pub struct C;\nfn f() -> super::b::B { super::b::B }\n",
            },
            "a::b",
            "a::c",
        )

    def test_super_super(self):
        self.assert_cycle(
            {
                "lib.rs": "mod x;\nmod y;\n",
                "x/mod.rs": "mod deep;\n",
                "x/deep.rs": "use super::super::y::Y;\npub struct D;\n",
                "y.rs": "pub struct Y;\nuse crate::x::deep::D;\n",
            },
            "x",
            "y",
        )

    def test_crate_paths_in_code(self):
        self.assert_cycle(
            {
                "lib.rs": "pub mod x;\npub mod y;\n",
                "x.rs": "pub fn f() { crate::y::g() }\n",
                "y.rs": "pub fn g() {}\npub fn h() { crate :: x :: f() }\n",
            },
            "x",
            "y",
        )

    def test_self_reexport_followed(self):
        # b uses a's re-export, which a takes from c through `self::`: b depends on c.
        self.assert_cycle(
            {
                "lib.rs": "mod a;\n",
                "a/mod.rs": "mod b;\nmod c;\npub use self::c::Shared;\n",
                "a/b.rs": "use super::Shared;\npub struct B;\n",
                "a/c.rs": "pub struct Shared;\nuse super::b::B;\n",
            },
            "a::b",
            "a::c",
        )

    def test_pub_use(self):
        self.assert_cycle(
            {
                "lib.rs": "mod a;\nmod b;\n",
                "a.rs": "pub(crate) use crate::b::B;\npub struct A;\n",
                "b.rs": "pub struct B;\npub use super::a::A as Alias;\n",
            },
            "a",
            "b",
        )

    def test_nested_groups(self):
        self.assert_cycle(
            {
                "lib.rs": "mod m;\nmod n;\nmod o;\n",
                "m.rs": "use crate::{o::O, n::{deep::{self, D}, N as Enn}};\npub struct M;\n",
                "n/mod.rs": "pub mod deep;\npub struct N;\n",
                "n/deep.rs": "use crate::{\n    m::{M},\n};\npub struct D;\n",
                "o.rs": "pub struct O;\n",
            },
            "m",
            "n",
        )

    def test_group_with_self(self):
        self.assert_cycle(
            {
                "lib.rs": "mod p;\nmod q;\n",
                "p.rs": "use super::q::{self};\npub struct P;\n",
                "q.rs": "use super::{p::{self as pee}};\n",
            },
            "p",
            "q",
        )

    def test_bare_use_through_import(self):
        self.assert_cycle(
            {
                "lib.rs": "mod a;\nmod b;\n",
                "a.rs": "use crate::b;\nuse b::inner::X;\n",
                "b/mod.rs": "pub mod inner;\n",
                "b/inner.rs": "pub struct X;\nfn f() { super::super::a::g() }\n",
            },
            "a",
            "b",
        )

    def test_mod_rs_and_flat_file_mix(self):
        self.assert_cycle(
            {
                "lib.rs": "mod a;\nmod b;\n",
                "a.rs": "mod inner;\n",
                "a/inner.rs": "use super::super::b::deep::X;\npub struct Y;\n",
                "b/mod.rs": "pub mod deep;\n",
                "b/deep.rs": "pub struct X;\nuse crate::a::inner::Y;\n",
            },
            "a",
            "b",
        )

    def test_path_attribute(self):
        self.assert_cycle(
            {
                "lib.rs": 'mod a;\n#[path = "elsewhere/bee.rs"]\nmod b;\n',
                "a.rs": "use crate::b::B;\npub struct A;\n",
                "elsewhere/bee.rs": "pub struct B;\nuse crate::a::A;\n",
            },
            "a",
            "b",
        )

    def test_inline_module(self):
        self.assert_cycle(
            {
                "lib.rs": "mod a;\nmod b {\n    pub fn f() { super::a::g() }\n}\n",
                "a.rs": "pub fn g() {}\nuse crate::b::f;\n",
            },
            "a",
            "b",
        )

    def test_nested_directories(self):
        self.assert_cycle(
            {
                "lib.rs": "pub mod daemon;\n",
                "daemon/mod.rs": "pub mod server;\npub mod store;\n",
                "daemon/server/mod.rs": "pub mod listener;\n",
                "daemon/server/listener.rs": "use crate::daemon::store::records::Record;\npub struct L;\n",
                "daemon/store.rs": "pub mod records;\n",
                "daemon/store/records.rs": "pub struct Record;\nuse super::super::server::listener::L;\n",
            },
            "daemon::server",
            "daemon::store",
        )

    def test_three_way_cycle(self):
        self.assert_cycle(
            {
                "lib.rs": "mod a;\nmod b;\nmod c;\n",
                "a.rs": "use crate::b::B;\npub struct A;\n",
                "b.rs": "use crate::c::C;\npub struct B;\n",
                "c.rs": "use crate::a::A;\npub struct C;\n",
            },
            "a",
            "b",
            "c",
        )

    def test_child_uses_parent(self):
        self.assert_no_cycle(
            {
                "lib.rs": "mod a;\npub struct Root;\n",
                "a/mod.rs": "mod b;\npub struct P;\nuse self::b::B;\nuse crate::Root;\n",
                "a/b.rs": "use super::P;\nuse crate::a::P as Q;\nuse super::super::Root;\npub struct B;\n",
            }
        )

    def test_one_way_is_no_cycle(self):
        files = {
            "lib.rs": "mod a;\nmod b;\n",
            "a.rs": "use super::b::B;\n",
            "b.rs": "pub struct B;\nuse std::fmt;\nuse ::core::mem;\n",
        }
        self.assert_no_cycle(files)
        with plant(files) as src:
            _, edges, _ = module_cycles.check(src)
        self.assertEqual(set(edges), {(("a",), ("b",))})

    def test_tests_comments_and_strings_do_not_count(self):
        self.assert_no_cycle(
            {
                "lib.rs": "mod a;\nmod b;\n",
                "a.rs": "use crate::b::B;\n",
                "b.rs": textwrap.dedent(
                    """\
                    pub struct B;
                    // use crate::a::A;
                    /* crate::a::f() /* nested */ crate::a::f() */
                    const S: &str = "crate::a::f()";
                    const R: &str = r#"use crate::a::A;"#;
                    const C: char = '"';
                    fn f<'a>(x: &'a str) -> &'a str { x }
                    #[cfg(test)]
                    mod tests {
                        use crate::a::*;
                    }
                    #[cfg(test)]
                    use crate::a::helper;
                    #[cfg(test)]
                    mod more_tests;
                    """
                ),
                "b/more_tests.rs": "use crate::a::A;\n",
            }
        )


if __name__ == "__main__":
    unittest.main()
