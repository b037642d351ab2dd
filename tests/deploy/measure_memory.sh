#!/usr/bin/env bash
# Peak memory of shrmd per job (docs/deploy.md, "Sizing"): for each job, a fresh shrmd
# (--max-jobs 1 --job-threads 1 --cache-mib 0, loopback, temp spool) runs one
# `shrm prefilter --server` on a bundled 1024 x 512 map; the table shows the daemon's VmHWM
# (peak resident set, /proc/PID/status) when idle and after the job, and the SHRM file's size.
# Then two jobs at once under the shipped limits (--max-jobs 2 --cache-mib 512).
#
# Usage: measure_memory.sh SHRMD SHRM REPO_ROOT   (not part of ctest: it takes ~1 min)
set -euo pipefail
[ $# -eq 3 ] || { echo "usage: $0 SHRMD SHRM REPO_ROOT" >&2; exit 2; }
SHRMD=$(readlink -f "$1")
SHRM=$(readlink -f "$2")
MAP="$(readlink -f "$3")/data/envmaps/city.exr"
TMP=$(mktemp -d "${TMPDIR:-/tmp}/shrm_memory.XXXXXX")
PID=""
cleanup() {
  [ -n "$PID" ] && kill -KILL "$PID" 2>/dev/null && wait "$PID" 2>/dev/null
  rm -rf "$TMP"
}
trap cleanup EXIT

start() { # shrmd flags...
  local port
  port=$(/usr/bin/python3 -c 'import socket; s = socket.socket(); s.bind(("127.0.0.1", 0)); print(s.getsockname()[1])')
  rm -rf "$TMP/spool"
  "$SHRMD" --listen "127.0.0.1:$port" --spool-dir "$TMP/spool" "$@" >"$TMP/shrmd.log" 2>&1 &
  PID=$!
  for _ in $(seq 100); do
    grep -q '"event":"listening"' "$TMP/shrmd.log" && break
    sleep 0.1
  done
  sleep 0.5 # settle: the idle figure is taken after start-up
  SERVER="127.0.0.1:$port"
}
stop() {
  kill -TERM "$PID"
  wait "$PID" || true
  PID=""
}
hwm_kib() { awk '/VmHWM/ { print $2 }' "/proc/$PID/status"; }

echo "| job (\`shrm prefilter\` options) | SHRM | idle MiB | peak MiB | job MiB | file MiB |"
echo "|---|---|---:|---:|---:|---:|"
while read -r opts; do
  start --max-jobs 1 --job-threads 1 --cache-mib 0
  idle=$(hwm_kib)
  # shellcheck disable=SC2086
  line=$("$SHRM" prefilter --env "$MAP" $opts -o "$TMP/x.shrm.exr" --server "$SERVER" | head -n 1)
  peak=$(hwm_kib)
  stop
  size=$(stat -c %s "$TMP/x.shrm.exr")
  rm -f "$TMP/x.shrm.exr"
  desc=${line#*global SHRM, }
  # shellcheck disable=SC2016 # the backquotes are Markdown
  printf '| `%s` | %s | %d | %d | %d | %.1f |\n' "$opts" "$desc" $((idle / 1024)) \
    $((peak / 1024)) $(((peak - idle) / 1024)) "$(echo "$size / 1048576" | bc -l)"
done <<'EOF'
--brdf phong:s=32 --size 16
--brdf lambert
--brdf phong:s=32
--brdf microfacet:sigma=0.3
--brdf microfacet:sigma=0.2
--brdf microfacet:sigma=0.1
--brdf microfacet:sigma=0.05
--brdf microfacet:sigma=0.1 --epsilon 0.01
EOF

start --max-jobs 2 --job-threads 1 --cache-mib 512
idle=$(hwm_kib)
clients=()
for i in 1 2; do
  "$SHRM" prefilter --env "$MAP" --brdf microfacet:sigma=0.1 --epsilon 0.01 \
    -o "$TMP/y$i.shrm.exr" --server "$SERVER" >/dev/null &
  clients+=("$!")
done
wait "${clients[@]}"
peak=$(hwm_kib)
stop
echo
echo "two microfacet:sigma=0.1 --epsilon 0.01 jobs at once (--max-jobs 2 --cache-mib 512):" \
  "idle $((idle / 1024)) MiB, peak $((peak / 1024)) MiB"
