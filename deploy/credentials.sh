#!/usr/bin/env bash
# Makes the compose cluster's shared files in deploy/credentials (or $REM_CREDENTIALS),
# keeping any that exist: the cluster secret, one TLS certificate for the name rem.cluster
# and its key, given to the user the daemons run as (SUNRAY_USER, default 65534:65534).
# It runs the image's own `rem credentials` as root in a throw-away container with no
# network, so it needs docker, not sudo.
#
#   deploy/build-image.sh && deploy/credentials.sh
set -euo pipefail
here="$(cd "$(dirname "$0")" && pwd)"
dir="${REM_CREDENTIALS:-$here/credentials}"
mkdir -p "$dir"
dir="$(cd "$dir" && pwd)"
docker run --rm --network none --user 0:0 --entrypoint /bin/rem \
  -v "$dir:/credentials" "${SUNRAY_IMAGE:-sunray-rem:latest}" \
  credentials /credentials --owner "${SUNRAY_USER:-65534:65534}"
