#!/usr/bin/env bash
# Builds the `sunray-rem:latest` container image from our own release binaries, with no
# registry and no base image: a FROM-scratch image holding remd, rem, sunray and rem-echo
# (the load generator's spinner), the shared libraries `ldd` lists for them, the dynamic
# loader, and empty /tmp and state folders.
#
#   deploy/build-image.sh            # builds the release binaries first
#   SKIP_CARGO=1 BIN_DIR=DIR deploy/build-image.sh   # uses the binaries in DIR as they are
#   SUNRAY_IMAGE=name:tag deploy/build-image.sh      # another tag
#   PGO=1 deploy/build-image.sh   # sunray from deploy/pgo-build.sh (profile-guided, about 10%
#                                 # fewer instructions, the same images); the others as above
set -euo pipefail
cd "$(dirname "$0")/.."
bin_dir="${BIN_DIR:-${CARGO_TARGET_DIR:-target}/release}"
if [ -z "${SKIP_CARGO:-}" ]; then
  cargo build --release -p rem -p sunray --bins
fi
pgo_sunray=""
if [ -n "${PGO:-}" ]; then
  deploy/pgo-build.sh
  pgo_sunray="${CARGO_TARGET_DIR:-target}/pgo/sunray"
fi
ctx="$(mktemp -d)"
trap 'rm -rf "$ctx"' EXIT
root="$ctx/root"
mkdir -p "$root/bin" "$root/tmp" "$root/var/lib/rem" "$root/etc"
chmod 1777 "$root/tmp" "$root/var/lib/rem"
image="${SUNRAY_IMAGE:-sunray-rem:latest}"
for b in remd rem sunray rem-echo; do
  from="$bin_dir/$b"
  if [ "$b" = sunray ] && [ -n "$pgo_sunray" ]; then from="$pgo_sunray"; fi
  cp "$from" "$root/bin/$b"
  # Release builds keep line tables for profiling; the image does not need them.
  if command -v strip >/dev/null; then strip --strip-debug "$root/bin/$b"; fi
  ldd "$from" | awk '/=> \// {print $3} /^[ \t]*\/.*ld-linux/ {print $1}' \
    | while read -r lib; do
        mkdir -p "$root$(dirname "$lib")"
        cp -L "$lib" "$root$lib"
      done
done
printf 'hosts: files dns\n' > "$root/etc/nsswitch.conf"
printf 'root:x:0:0:root:/:/bin/remd\nnobody:x:65534:65534:nobody:/nonexistent:/bin/remd\n' \
  > "$root/etc/passwd"
printf 'root:x:0:\nnogroup:x:65534:\n' > "$root/etc/group"
cp deploy/Dockerfile "$ctx/Dockerfile"
# The build time as a label: every build is a new image, even of the same binaries.
docker build -q --label "sunray.built=$(date -u +%Y-%m-%dT%H:%M:%SZ)" -t "$image" "$ctx" >/dev/null
echo "built $image"
