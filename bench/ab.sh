#!/usr/bin/env bash
# Two sunray binaries, old (A) against new (B), on Haines's SPD scenes: each renders each scene
# RUNS times (default 5), alternating A, B, A, B..., 512x512, one thread, one sample; prints the
# best CPU seconds (build + render, from --stats-json) of each, the ratio A/B (> 1: B is
# faster) and whether the last two PNGs are byte-identical. Alternating in one run is what
# makes the ratio meaningful on a shared, noisy machine.
# Usage: bench/ab.sh OLD_SUNRAY NEW_SUNRAY [db:size ...]   (default: every SPD scene at its
# default size; OUT=dir for the scenes and images, default target/ab-bench)
set -euo pipefail
[ $# -ge 2 ] || { sed -n 2,8p "$0" >&2; exit 2; }
A=$1; B=$2; shift 2
OUT=${OUT:-target/ab-bench}
mkdir -p "$OUT"
SCENES=${*:-tetra:6 mount:6 balls:4 gears:4 rings:7 tree:11 teapot:6 lattice:12 shells:5 jacks:1 sombrero:1}
cpu() { python3 -c "import json,sys; print(json.load(open(sys.argv[1]))['time']['cpu_s'])" "$1"; }
echo "| scene | A cpu s | B cpu s | A / B | images |"
echo "|---|---:|---:|---:|---|"
for spec in $SCENES; do
  db=${spec%:*}; size=${spec#*:}; name=$db$size
  "$B" spd "$db" --size "$size" -o "$OUT/$name.nff"
  best_a=1e99; best_b=1e99
  for _ in $(seq "${RUNS:-5}"); do
    for side in A B; do
      bin=$A; [ "$side" = B ] && bin=$B
      "$bin" render "$OUT/$name.nff" -o "$OUT/$name-$side.png" --threads 1 --samples 1 \
        --resolution 512x512 --stats-json "$OUT/$name-$side.json" -q
      c=$(cpu "$OUT/$name-$side.json")
      if [ "$side" = A ]; then best_a=$(python3 -c "print(min($best_a, $c))"); \
      else best_b=$(python3 -c "print(min($best_b, $c))"); fi
    done
  done
  same=$(cmp -s "$OUT/$name-A.png" "$OUT/$name-B.png" && echo identical || echo DIFFERENT)
  python3 -c "print(f'| $name | {$best_a:.4f} | {$best_b:.4f} | {$best_a / $best_b:.3f}x | $same |')"
done
