#!/usr/bin/env bash
# The load generator: makes chosen workstations of the compose cluster "heavily loaded", as
# the other users' work in the thesis's Tables 4.5 to 4.8. Each spinner is a `rem-echo spin`
# run inside the workstation's container (docker-compose exec), so its CPU use is in that
# host's cgroup and counts against its CPU limit, where remd measures load.
#
#   deploy/load.sh start [--spinners N] [--seconds S] HOST...   # N spinners per host (1), S s (3600)
#   deploy/load.sh stop HOST...                                 # ends them (needs root, as docker)
#   deploy/load.sh status                                       # rem hosts as ws1 sees them
#
# COMPOSE_FILE / COMPOSE_PROJECT_NAME select the cluster as for docker-compose; by default
# deploy/docker-compose.yml. Set COMPOSE to the command (default: docker-compose, else
# "docker compose").
set -euo pipefail
here="$(cd "$(dirname "$0")" && pwd)"
export COMPOSE_FILE="${COMPOSE_FILE:-$here/docker-compose.yml}"
if [ -z "${COMPOSE:-}" ]; then
  if command -v docker-compose >/dev/null; then COMPOSE=docker-compose; else COMPOSE="docker compose"; fi
fi
usage() { sed -n '2,13p' "$0" >&2; exit 2; }
[ $# -ge 1 ] || usage
cmd="$1"; shift
spinners=1; seconds=3600
while [ $# -gt 0 ]; do
  case "$1" in
    --spinners) spinners="$2"; shift 2 ;;
    --seconds) seconds="$2"; shift 2 ;;
    -*) usage ;;
    *) break ;;
  esac
done
case "$cmd" in
  start)
    [ $# -ge 1 ] || usage
    for host in "$@"; do
      for _ in $(seq "$spinners"); do
        $COMPOSE exec -d -T "$host" /bin/rem-echo spin "$seconds"
      done
      echo "loaded $host with $spinners spinner(s) for $seconds s"
    done ;;
  stop)
    [ $# -ge 1 ] || usage
    for host in "$@"; do
      id="$($COMPOSE ps -q "$host")"
      [ -n "$id" ] || { echo "no container for $host" >&2; continue; }
      pids="$(docker top "$id" -eo pid,args | awk '/rem-echo spin/ {print $1}')"
      [ -z "$pids" ] || kill $pids
      echo "unloaded $host"
    done ;;
  status)
    $COMPOSE exec -T ws1 /bin/rem hosts ;;
  *) usage ;;
esac
