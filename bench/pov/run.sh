#!/usr/bin/env bash
# SunRay against POV-Ray 3.7, side by side: every one of Haines's SPD scenes at his default
# size (SCENES overrides the list, e.g. SCENES="tetra:6 teapot:12") at 512x512, one thread each, no antialiasing, ray tree depth 5. The POV-Ray scenes are written
# by `sunray convert SCENE -o SCENE.pov` (yari::pov) from the same compiled world SunRay
# renders. Prints a Markdown table: both trace times (POV-Ray's own "Trace Time"; SunRay's
# build + render time), the CPU seconds of each (the fairer figure on a shared machine; SunRay's
# includes building its BVH, POV-Ray's is its trace only), rays, and the ratios, best of REPEAT runs (default 3).
# Usage: [REPEAT=3] [RES=512] [SCENES="db:size ..."] [SUNRAY=path] bench/pov/run.sh [OUTDIR]   (default OUTDIR: target/pov-bench)
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
echo "| scene | SunRay build + render s | SunRay CPU s | SunRay rays | POV-Ray trace s | POV-Ray CPU s | POV-Ray rays | POV / SunRay (wall) | POV / SunRay (CPU) |"
echo "|---|---:|---:|---:|---:|---:|---:|---:|---:|"
SCENES=${SCENES:-tetra:6 mount:6 balls:4 gears:4 rings:7 tree:11 teapot:6 lattice:12 shells:5 jacks:1 sombrero:1}
for spec in $SCENES; do
  db=${spec%:*}; size=${spec#*:}; name=$db$size
  "$SUNRAY" spd "$db" --size "$size" -o "$OUT/$name.yari"
  "$SUNRAY" convert "$OUT/$name.yari" -o "$OUT/$name.pov"
  # Each renderer runs REPEAT times; the table keeps the best wall and the best CPU time.
  sr_s=; sr_cpu=; pov_s=; pov_cpu=
  for _ in $(seq "${REPEAT:-3}"); do
    "$SUNRAY" render "$OUT/$name.yari" -o "$OUT/$name-sunray.png" --threads 1 --samples 1 \
        --resolution "${RES}x${RES}" --stats-json "$OUT/$name-sunray.json" -q
    read -r s c rays < <(python3 -c "import json,sys; j=json.load(open(sys.argv[1])); t=j['time']; print(t['preprocess_s'] + t['render_s'], t['cpu_s'], j['rays']['total'])" "$OUT/$name-sunray.json")
    sr_s=$(python3 -c "print(min(float('$s'), float('${sr_s:-inf}')))")
    sr_cpu=$(python3 -c "print(min(float('$c'), float('${sr_cpu:-inf}')))")
    sr_rays=$rays
    povray "+I$OUT/$name.pov" "+O$OUT/$name-pov.png" "+W$RES" "+H$RES" +FN File_Gamma=1.0 -D +WT1 -A \
        +GS +GR -GD 2> "$OUT/$name-pov.log" >/dev/null || { cat "$OUT/$name-pov.log" >&2; exit 1; }
    s=$(sed -n 's/.*Trace Time: .*(\s*\([0-9.]*\) seconds).*/\1/p' "$OUT/$name-pov.log" | head -1)
    c=$(sed -n 's/.*using 1 thread(s) with \([0-9.]*\) CPU-seconds.*/\1/p' "$OUT/$name-pov.log" | tail -1)
    pov_s=$(python3 -c "print(min(float('$s'), float('${pov_s:-inf}')))")
    pov_cpu=$(python3 -c "print(min(float('$c'), float('${pov_cpu:-inf}')))")
  done
  # POV-Ray's "Rays" counts camera, reflected and refracted rays; shadow rays are its
  # "Shadow Ray Tests".
  pov_rays=$(python3 - "$OUT/$name-pov.log" <<'PY'
import re, sys
text = open(sys.argv[1]).read()
rays = re.search(r"Rays:\s+(\d+)", text)
shadow = re.search(r"Shadow Ray Tests:\s+(\d+)", text)
print(sum(int(m.group(1)) for m in (rays, shadow) if m))
PY
)
  ratio=$(python3 -c "print(f'{float(\"$pov_s\")/float(\"$sr_s\"):.2f}')")
  cpu_ratio=$(python3 -c "print(f'{float(\"$pov_cpu\")/float(\"$sr_cpu\"):.2f}')")
  printf '| %s | %.3f | %.3f | %s | %.3f | %.3f | %s | %sx | %sx |\n' "$name" "$sr_s" "$sr_cpu" "$sr_rays" \
      "$pov_s" "$pov_cpu" "$pov_rays" "$ratio" "$cpu_ratio"
done
