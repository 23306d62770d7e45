#!/bin/sh
# Rebuilds the modeler examples from their scripts: for each of king and bat, the project
# (NAME.modeler.json, not committed), the YARI scene (NAME.yari), the four-view preview
# (NAME-preview.png) and a render by sunray (NAME.png).
#
#   examples/modeler/build.sh            # uses `cargo run` for both programs
#   MODELER=modeler SUNRAY=sunray examples/modeler/build.sh   # installed binaries
set -eu
cd "$(dirname "$0")"
MODELER=${MODELER:-"cargo run -q -p modeler-cli --bin modeler --"}
SUNRAY=${SUNRAY:-"cargo run -q -p sunray --bin sunray --"}
for name in king bat; do
    $MODELER -p "$name.modeler.json" script "$name.modeler"
    $MODELER -p "$name.modeler.json" export -o "$name.yari"
    $MODELER -p "$name.modeler.json" preview -o "$name-preview.png" --size 240
    $SUNRAY render "$name.yari" -o "$name.png" -q
    echo "built $name.yari, $name-preview.png, $name.png"
done
