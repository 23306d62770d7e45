#!/usr/bin/env bash
# Builds the `sunray-rem:latest` container image from our own release binaries, with no
# registry and no base image: a FROM-scratch image holding remd, rem and sunray, the shared
# libraries `ldd` lists for them, the dynamic loader, and empty /tmp and state folders.
#
#   deploy/build-image.sh            # builds the release binaries first
#   SKIP_CARGO=1 BIN_DIR=DIR deploy/build-image.sh   # uses the binaries in DIR as they are
set -euo pipefail
cd "$(dirname "$0")/.."
bin_dir="${BIN_DIR:-${CARGO_TARGET_DIR:-target}/release}"
if [ -z "${SKIP_CARGO:-}" ]; then
  cargo build --release -p rem -p sunray --bins
fi
ctx="$(mktemp -d)"
trap 'rm -rf "$ctx"' EXIT
root="$ctx/root"
mkdir -p "$root/bin" "$root/tmp" "$root/var/lib/rem" "$root/etc"
chmod 1777 "$root/tmp"
for b in remd rem sunray; do
  cp "$bin_dir/$b" "$root/bin/$b"
  ldd "$bin_dir/$b" | awk '/=> \// {print $3} /^[ \t]*\/.*ld-linux/ {print $1}' \
    | while read -r lib; do
        mkdir -p "$root$(dirname "$lib")"
        cp -L "$lib" "$root$lib"
      done
done
printf 'hosts: files dns\n' > "$root/etc/nsswitch.conf"
printf 'root:x:0:0:root:/:/bin/remd\n' > "$root/etc/passwd"
cp deploy/Dockerfile "$ctx/Dockerfile"
docker build -q -t sunray-rem:latest "$ctx"
echo "built sunray-rem:latest"
