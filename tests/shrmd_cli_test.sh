#!/usr/bin/env bash
# shrmd's command line (docs/server.md "Operations"): usage errors exit 2 with a line naming the
# flag and, for a number, its range; a config file's value is checked as the flag's; --help and
# --version exit 0; a config line with an unknown key is a start-up error (1). None of these
# cases gets as far as listening.
#
# Usage: shrmd_cli_test.sh SHRMD   (CTest: shrmd_cli_test)
set -uo pipefail

if [ $# -ne 1 ]; then
  echo "usage: $0 SHRMD" >&2
  exit 2
fi
SHRMD=$1
[ -x "$SHRMD" ] || { echo "not executable: $SHRMD" >&2; exit 2; }
TMP=$(mktemp -d)
trap 'rm -rf "$TMP"' EXIT

FAILURES=0
CHECKS=0
# expect NAME RC REGEX ARGS...: exit code RC within 20 s, stderr (or, for RC 0, stdout) matching
# REGEX.
expect() {
  local name=$1 want=$2 regex=$3
  shift 3
  CHECKS=$((CHECKS + 1))
  timeout 20 "$SHRMD" "$@" >"$TMP/$name.out" 2>"$TMP/$name.err"
  local rc=$?
  local text="$TMP/$name.err"
  [ "$want" -eq 0 ] && text="$TMP/$name.out"
  if [ "$rc" -ne "$want" ]; then
    echo "FAIL: $name: exit code $rc, expected $want; stderr: $(head -c 300 "$TMP/$name.err")"
    FAILURES=$((FAILURES + 1))
  elif ! grep -Eq -- "$regex" "$text"; then
    echo "FAIL: $name: output does not match /$regex/: $(head -c 300 "$text")"
    FAILURES=$((FAILURES + 1))
  else
    echo "ok: $name (exit $rc): $(head -n 1 "$text")"
  fi
}

# Every case listens on a loopback port of its own choosing, so a case that did start would not
# collide with anything (and the 20 s timeout would fail it).
L=(--listen 127.0.0.1:0 --spool-dir "$TMP/spool")
expect help 0 '--max-jobs' --help
expect version 0 '^shrmd [0-9]' --version
expect max_jobs_zero 2 "^--max-jobs: must be > 0, got '0'$" "${L[@]}" --max-jobs 0
expect negative_grace 2 "^--grace-period: must be >= 0, got '-1'$" "${L[@]}" --grace-period -1
expect metrics_port_range 2 "^--metrics-port: must be in \\[-1, 65535\\], got '70000'$" \
  "${L[@]}" --metrics-port 70000
expect unknown_flag 2 '^unknown option --bogus$' "${L[@]}" --bogus
expect misspelt_flag 2 '^unknown option --max-job \(did you mean --max-jobs\?\)$' "${L[@]}" --max-job 2
expect missing_config 2 '^--config: File does not exist' "${L[@]}" --config "$TMP/none.conf"
printf 'max-jobs = 0\n' >"$TMP/zero.conf"
expect config_value 2 "^--max-jobs: must be > 0, got '0'$" "${L[@]}" --config "$TMP/zero.conf"
printf 'bogus-key = 3\n' >"$TMP/unknown.conf"
expect config_key 1 "^shrmd: error: .*unknown\\.conf: config line 1: unknown key 'bogus-key'$" \
  "${L[@]}" --config "$TMP/unknown.conf"

echo "$CHECKS checks, $FAILURES failures"
[ "$FAILURES" -eq 0 ]
