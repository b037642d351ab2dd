#!/usr/bin/env bash
# The main job: installs what is missing, builds, and analyzes a bundled real HDR map
# (SH coefficients and the order needed for a tolerance, SHRM paper eq. 5.16).
# Extra arguments go to `shrm analyze`, e.g. scripts/demo.sh data/envmaps/city.exr --epsilon 0.001
set -euo pipefail
cd "$(dirname "$0")/.."
bash scripts/install-deps.sh
bash scripts/build.sh >/dev/null
if [ $# -eq 0 ]; then set -- data/envmaps/courtyard.exr; fi
"${SHRM_BUILD_DIR:-build}/client/shrm" analyze "$@"
