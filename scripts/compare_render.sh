#!/usr/bin/env bash
# Render speed of two sunray builds, alternately, on Haines's SPD scenes (tetra 6, mount 6,
# balls 4), and whether their images are byte-identical:
#
#   scripts/compare_render.sh OLD_SUNRAY NEW_SUNRAY
#
# ROUNDS (3), SAMPLES (16 per pixel) and RES (512x512) set the runs; the figure is each
# build's render seconds (from --stats-json) summed over the rounds, and new/old of the sums.
set -euo pipefail
old=$1 new=$2
rounds=${ROUNDS:-3} samples=${SAMPLES:-16} res=${RES:-512x512}
work=$(mktemp -d); trap 'rm -rf "$work"' EXIT
render_s() { python3 -c "import json,sys; print(json.load(open(sys.argv[1]))['time']['render_s'])" "$1"; }
for scene in tetra mount balls; do
  "$new" spd "$scene" -o "$work/$scene.nff"
  t_old=0 t_new=0
  for _ in $(seq "$rounds"); do
    for which in old new; do
      "${!which}" render "$work/$scene.nff" --resolution "$res" --samples "$samples" -q \
        -o "$work/$which.png" --stats-json "$work/$which.json"
      s=$(render_s "$work/$which.json")
      if [ "$which" = old ]; then t_old=$(python3 -c "print($t_old + $s)"); else t_new=$(python3 -c "print($t_new + $s)"); fi
    done
  done
  same=identical; cmp -s "$work/old.png" "$work/new.png" || same=DIFFERENT
  python3 -c "print(f'{\"$scene\":6} old {$t_old/$rounds:.3f} s  new {$t_new/$rounds:.3f} s  new/old {$t_new/$t_old:.3f}  images $same')"
done
