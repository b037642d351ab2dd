#!/usr/bin/env bash
# The test command: installs what is missing, checks formatting, builds everything (library,
# CLI, tests, benchmarks) and runs the whole test suite.
set -euo pipefail
cd "$(dirname "$0")/.."
bash scripts/install-deps.sh
bash scripts/check-format.sh
bash scripts/build.sh
ctest --test-dir "${SHRM_BUILD_DIR:-build}" --output-on-failure -j "$(nproc)"
