#!/usr/bin/env bash
# Runs a viewer test program with an X display: the current one, or a private Xvfb server
# (`xvfb-run -a`, Mesa llvmpipe). Usage: viewer_xvfb.sh PROGRAM [ARGS...]
set -euo pipefail
if [ -n "${DISPLAY:-}" ] && command -v xdpyinfo >/dev/null 2>&1 && xdpyinfo >/dev/null 2>&1; then
  exec "$@"
fi
if ! command -v xvfb-run >/dev/null 2>&1; then
  echo "viewer_xvfb.sh: no X display and no xvfb-run (apt-get install xvfb xauth)" >&2
  exit 1
fi
# A random first display number: two xvfb-run -a starting at once would both pick :99.
exec xvfb-run -a -n $((100 + RANDOM % 800)) -s "-screen 0 1280x1024x24" "$@"
