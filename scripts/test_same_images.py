"""Tests of same_images.sh: two stand-in sunray builds (small shell programs that answer
`spd` and `render` as sunray does, writing the scene and the options into the "image"), one of
them with a planted defect.

    python3 -m unittest discover -s scripts -p 'test_*.py'
"""
import os
import subprocess
import tempfile
import unittest

HERE = os.path.dirname(os.path.abspath(__file__))
SCRIPT = os.path.join(HERE, "same_images.sh")

# A stand-in build: `spd DB --size N -o F` writes "DB N" to F; `render SCENE ... -o OUT`
# writes the scene's text and every option but the output's path to OUT. DEFECT is shell code
# run on the render's arguments before it writes (the planted defect).
STAND_IN = """#!/usr/bin/env bash
set -eu
cmd=$1; shift
out=""
args=()
while [ $# -gt 0 ]; do
  case "$1" in
    -o) out=$2; shift 2 ;;
    *) args+=("$1"); shift ;;
  esac
done
if [ "$cmd" = spd ]; then
  echo "${args[*]}" > "$out"
  exit 0
fi
scene=${args[0]}
extra=""
%s
{ cat "$scene"; echo "${args[*]:1}$extra"; } > "$out"
"""


class Planted(unittest.TestCase):
    def build(self, directory, name, defect=""):
        path = os.path.join(directory, name)
        with open(path, "w") as f:
            f.write(STAND_IN % defect)
        os.chmod(path, 0o755)
        return path

    def run_script(self, ref, new):
        env = dict(os.environ, SCENES="tetra:2 balls:1", RES="8x8")
        return subprocess.run(
            [SCRIPT, ref, new], capture_output=True, text=True, env=env, timeout=60
        )

    def test_the_same_build_passes(self):
        with tempfile.TemporaryDirectory() as d:
            a = self.build(d, "a")
            b = self.build(d, "b")
            r = self.run_script(a, b)
            self.assertEqual(r.returncode, 0, r.stderr)
            self.assertIn("every image the same", r.stdout)
            self.assertEqual(r.stdout.count("same      "), 6)

    def test_a_build_that_draws_differently_under_one_option_fails(self):
        with tempfile.TemporaryDirectory() as d:
            a = self.build(d, "a")
            defect = 'case " ${args[*]} " in *" --target-error "*) extra=" off by one";; esac'
            b = self.build(d, "b", defect)
            r = self.run_script(a, b)
            self.assertEqual(r.returncode, 1)
            self.assertIn("DIFFERENT tetra2 --target-error 0.05", r.stdout)
            self.assertIn("balls1 --target-error 0.05: the images differ", r.stderr)
            self.assertIn("not the same images: 2 of the renders above", r.stderr)
            self.assertIn("same      tetra2 (plain)", r.stdout)

    def test_a_build_that_fails_to_render_fails(self):
        with tempfile.TemporaryDirectory() as d:
            a = self.build(d, "a")
            b = self.build(d, "b", 'echo "error: out of luck" >&2; exit 1')
            r = self.run_script(a, b)
            self.assertEqual(r.returncode, 1)
            self.assertIn("tetra2 (plain): the new build failed: error: out of luck", r.stderr)


if __name__ == "__main__":
    unittest.main()
