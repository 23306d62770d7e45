#!/usr/bin/env bash
# SunRay against POV-Ray 3.7, side by side: every one of Haines's SPD scenes at his default
# size (SCENES overrides the list, e.g. SCENES="tetra:6 teapot:12") at 512x512, one thread
# each, no antialiasing, ray tree depth 5.
#
# POV-Ray is given each scene in two forms and judged by the faster:
# - ours: `sunray convert SCENE -o SCENE.pov` (yari::pov), from the same compiled world SunRay
#   renders;
# - Haines's: the SDL his own generators write with `-r 4` (POV-Ray 3.1 syntax, each triangle
#   an object), which is how a POV-Ray user gets these scenes. Set HAINES_POV to a folder
#   holding NAME.pov for each scene (tetra6.pov, gears4.pov, ...) and the files they refer to
#   (sombrero's hf000.tga), made beside the project from his repository; see
#   docs/accuracy.md, "POV-Ray on its own terms". Without it that column is left empty.
#
# Prints a Markdown table: SunRay's build + render time and CPU seconds, POV-Ray's "Trace
# Time" and CPU seconds on each SDL, and the ratios against POV-Ray's faster SDL (by CPU
# seconds, the fairer figure on a shared machine; SunRay's include building its BVH,
# POV-Ray's are its trace only). Each figure is the best of REPEAT runs (default 5); the runs
# alternate SunRay, POV-Ray on ours, POV-Ray on Haines's.
# With SUNRAY_OLD=path, every round also runs that SunRay binary (before the new one), and a
# last column gives POV-Ray's faster SDL against it: two SunRays against the same POV-Ray runs,
# so a change of a few percent can be read through this machine's drift.
# SUNRAY=target/pgo/sunray times the profile-guided build that deploy/pgo-build.sh makes (the
# one PGO=1 deploy/build-image.sh puts in the farm's image); SUNRAY_OLD=target/release/sunray
# beside it gives the plain build's column in the same rounds.
# Usage: [REPEAT=5] [RES=512] [SCENES="db:size ..."] [SUNRAY=path] [SUNRAY_OLD=path]
#        [HAINES_POV=dir]
#        bench/pov/run.sh [OUTDIR]   (default OUTDIR: target/pov-bench)
set -euo pipefail
cd "$(dirname "$0")/../.."
OUT=${1:-target/pov-bench}
mkdir -p "$OUT"
if ! command -v povray >/dev/null; then
  echo "installing POV-Ray 3.7 (apt-get)" >&2
  apt-get update -qq && DEBIAN_FRONTEND=noninteractive apt-get install -y -qq povray >/dev/null
fi
SUNRAY=${SUNRAY:-}
if [ -z "$SUNRAY" ]; then
  cargo build --release -q -p sunray
  SUNRAY=${CARGO_TARGET_DIR:-target}/release/sunray
fi
RES=${RES:-512}
HAINES_POV=${HAINES_POV:-}
if [ -n "$HAINES_POV" ] && [ ! -d "$HAINES_POV" ]; then
  echo "HAINES_POV=$HAINES_POV is not a folder" >&2
  exit 2
fi

min() { python3 -c "import sys; print(min(float(a) for a in sys.argv[1:] if a))" "$@"; }

# povray_run SDL LOG [LIBRARY]: one POV-Ray render; prints "trace_s cpu_s".
povray_run() {
  local lib=()
  [ -n "${3:-}" ] && lib=("+L$3")
  povray "+I$1" "+O$OUT/pov-out.png" "+W$RES" "+H$RES" +FN File_Gamma=1.0 -D +WT1 -A \
      "${lib[@]}" +GS +GR -GD 2> "$2" >/dev/null || { cat "$2" >&2; exit 1; }
  local s c
  s=$(sed -n 's/.*Trace Time: .*(\s*\([0-9.]*\) seconds).*/\1/p' "$2" | head -1)
  c=$(sed -n 's/.*using 1 thread(s) with \([0-9.]*\) CPU-seconds.*/\1/p' "$2" | tail -1)
  echo "$s $c"
}

# POV-Ray's "Rays" counts camera, reflected and refracted rays; shadow rays are its
# "Shadow Ray Tests".
povray_rays() {
  python3 - "$1" <<'PY'
import re, sys
text = open(sys.argv[1]).read()
rays = re.search(r"Rays:\s+(\d+)", text)
shadow = re.search(r"Shadow Ray Tests:\s+(\d+)", text)
print(sum(int(m.group(1)) for m in (rays, shadow) if m))
PY
}

SUNRAY_OLD=${SUNRAY_OLD:-}
old_head=; old_rule=
if [ -n "$SUNRAY_OLD" ]; then
  old_head=" SUNRAY_OLD CPU s | POV / SUNRAY_OLD (CPU) |"; old_rule="---:|---:|"
fi
echo "| scene | SunRay build + render s | SunRay CPU s | SunRay rays | POV-Ray on ours: trace s / CPU s / rays | POV-Ray on Haines's: trace s / CPU s / rays | POV / SunRay (wall) | POV / SunRay (CPU) | POV-Ray's faster SDL |$old_head"
echo "|---|---:|---:|---:|---:|---:|---:|---:|---|$old_rule"
SCENES=${SCENES:-tetra:6 mount:6 balls:4 gears:4 rings:7 tree:11 teapot:6 lattice:12 shells:5 jacks:1 sombrero:1}
for spec in $SCENES; do
  db=${spec%:*}; size=${spec#*:}; name=$db$size
  "$SUNRAY" spd "$db" --size "$size" -o "$OUT/$name.yari"
  "$SUNRAY" convert "$OUT/$name.yari" -o "$OUT/$name.pov"
  haines=
  if [ -n "$HAINES_POV" ]; then
    haines=$HAINES_POV/$name.pov
    [ -f "$haines" ] || { echo "$haines is missing (Haines's \`$db -s $size -r 4\`)" >&2; exit 2; }
  fi
  sr_s=; sr_cpu=; ours_s=; ours_cpu=; hn_s=; hn_cpu=; old_cpu=
  for _ in $(seq "${REPEAT:-5}"); do
    if [ -n "$SUNRAY_OLD" ]; then
      "$SUNRAY_OLD" render "$OUT/$name.yari" -o "$OUT/$name-old.png" --threads 1 --samples 1 \
          --resolution "${RES}x${RES}" --stats-json "$OUT/$name-old.json" -q
      c=$(python3 -c "import json,sys; print(json.load(open(sys.argv[1]))['time']['cpu_s'])" "$OUT/$name-old.json")
      old_cpu=$(min "$c" "$old_cpu")
    fi
    "$SUNRAY" render "$OUT/$name.yari" -o "$OUT/$name-sunray.png" --threads 1 --samples 1 \
        --resolution "${RES}x${RES}" --stats-json "$OUT/$name-sunray.json" -q
    read -r s c sr_rays < <(python3 -c "import json,sys; j=json.load(open(sys.argv[1])); t=j['time']; print(t['preprocess_s'] + t['render_s'], t['cpu_s'], j['rays']['total'])" "$OUT/$name-sunray.json")
    sr_s=$(min "$s" "$sr_s"); sr_cpu=$(min "$c" "$sr_cpu")
    read -r s c < <(povray_run "$OUT/$name.pov" "$OUT/$name-pov.log")
    ours_s=$(min "$s" "$ours_s"); ours_cpu=$(min "$c" "$ours_cpu")
    if [ -n "$haines" ]; then
      read -r s c < <(povray_run "$haines" "$OUT/$name-haines.log" "$HAINES_POV")
      hn_s=$(min "$s" "$hn_s"); hn_cpu=$(min "$c" "$hn_cpu")
    fi
  done
  ours_rays=$(povray_rays "$OUT/$name-pov.log")
  pov_s=$ours_s; pov_cpu=$ours_cpu; faster=ours
  haines_cell="–"
  if [ -n "$haines" ]; then
    hn_rays=$(povray_rays "$OUT/$name-haines.log")
    haines_cell=$(printf '%.3f / %.3f / %s' "$hn_s" "$hn_cpu" "$hn_rays")
    if python3 -c "import sys; sys.exit(0 if float('$hn_cpu') < float('$ours_cpu') else 1)"; then
      pov_s=$hn_s; pov_cpu=$hn_cpu; faster="Haines's"
    fi
  fi
  ratio=$(python3 -c "print(f'{float(\"$pov_s\")/float(\"$sr_s\"):.2f}')")
  cpu_ratio=$(python3 -c "print(f'{float(\"$pov_cpu\")/float(\"$sr_cpu\"):.2f}')")
  old_cells=
  if [ -n "$SUNRAY_OLD" ]; then
    old_cells=$(python3 -c "print(f' {float(\"$old_cpu\"):.3f} | {float(\"$pov_cpu\")/float(\"$old_cpu\"):.2f}x |')")
  fi
  printf '| %s | %.3f | %.3f | %s | %.3f / %.3f / %s | %s | %sx | %sx | %s |%s\n' "$name" "$sr_s" \
      "$sr_cpu" "$sr_rays" "$ours_s" "$ours_cpu" "$ours_rays" "$haines_cell" "$ratio" \
      "$cpu_ratio" "$faster" "$old_cells"
done
