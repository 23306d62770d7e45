#!/usr/bin/env bash
# A profile-guided (PGO) build of `sunray`: the same code and the same images, about 10% fewer
# instructions on Haines's SPD scenes (2-15%; docs/renderer.md, "A profile-guided build").
#
#   deploy/pgo-build.sh        # writes target/pgo/sunray
#
# 1. builds sunray instrumented (-Cprofile-generate) in target/pgo/generate;
# 2. runs it on a training set it makes itself: every SPD database at a size below the
#    benchmarks' (rendered plain, with 4 Sobol samples and to an error), and the accuracy
#    scenes (area light, gloss, depth of field; `sunray bench scenes`) at 32x32, stratified,
#    Sobol and to an error, so no SPD scene of bench/pov/run.sh is trained on. Every training
#    run is a fixed amount of work on one thread, so two trainings count the same in all a
#    render runs per pixel (only std's randomly seeded hash tables probe differently);
# 3. merges the counts with llvm-profdata (rustup's llvm-tools component, installed if missing)
#    and builds again with -Cprofile-use in target/pgo/use;
# 4. checks with scripts/same_images.sh that the guided build writes byte-identical images to
#    the plain release build (built here, or brought up to date) and copies it to target/pgo/sunray.
# Both builds take the workspace's release profile and its target CPU (.cargo/config.toml);
# RUSTFLAGS replaces that file's flags, so the target CPU is given again here (PGO_TARGET_CPU,
# default x86-64-v3). deploy/build-image.sh uses it with PGO=1.
set -euo pipefail
cd "$(dirname "$0")/.."
target=${CARGO_TARGET_DIR:-target}
case $target in /*) ;; *) target="$(pwd)/$target" ;; esac
pgo="$target/pgo"
cpu=${PGO_TARGET_CPU:-x86-64-v3}
data="$pgo/profiles"
rm -rf "$data" "$pgo/train" "$pgo/sunray"
mkdir -p "$data" "$pgo/train"

profdata="$(rustc --print sysroot)/lib/rustlib/$(rustc -vV | sed -n 's/^host: //p')/bin/llvm-profdata"
if [ ! -x "$profdata" ]; then
  command -v rustup >/dev/null \
    || { echo "no llvm-profdata at $profdata, and no rustup to install it (llvm-tools)" >&2; exit 1; }
  echo "installing llvm-profdata (rustup component add llvm-tools)" >&2
  rustup component add llvm-tools >&2
fi
[ -x "$profdata" ] || { echo "no llvm-profdata at $profdata after installing llvm-tools" >&2; exit 1; }

echo "1/4 instrumented build" >&2
CARGO_TARGET_DIR="$pgo/generate" RUSTFLAGS="-C target-cpu=$cpu -Cprofile-generate=$data" \
  cargo build --release -q -p sunray --bin sunray
gen="$pgo/generate/release/sunray"

echo "2/4 training" >&2
train="$pgo/train"
for spec in tetra:5 mount:5 balls:3 gears:3 rings:5 tree:9 teapot:4 lattice:8 shells:4 jacks:2 sombrero:2; do
  db=${spec%:*} size=${spec#*:}
  "$gen" spd "$db" --size "$size" -o "$train/$db.nff"
  for opts in "" "--samples 4 --sampler sobol" "--target-error 0.03"; do
    # shellcheck disable=SC2086 # the options are words
    "$gen" render "$train/$db.nff" --resolution 192x192 --threads 1 -q $opts -o "$train/out.png"
  done
done
"$gen" bench scenes --accuracy-resolution 32 --out-dir "$train/accuracy" >/dev/null
for scene in "$train"/accuracy/*.yari; do
  for opts in "--samples 16" "--samples 16 --sampler sobol" "--target-error 0.02 --max-samples 64"; do
    # shellcheck disable=SC2086 # the options are words
    "$gen" render "$scene" --threads 1 -q $opts -o "$train/out.png"
  done
done

echo "3/4 guided build" >&2
"$profdata" merge -o "$pgo/sunray.profdata" "$data"
CARGO_TARGET_DIR="$pgo/use" RUSTFLAGS="-C target-cpu=$cpu -Cprofile-use=$pgo/sunray.profdata" \
  cargo build --release -q -p sunray --bin sunray

echo "4/4 the same images as the plain build" >&2
cargo build --release -q -p sunray --bin sunray
scripts/same_images.sh "$target/release/sunray" "$pgo/use/release/sunray" >/dev/null
cp "$pgo/use/release/sunray" "$pgo/sunray"
echo "built $pgo/sunray" >&2
