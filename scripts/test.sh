#!/usr/bin/env bash
# The test command: installs what is missing, checks formatting, builds everything (library,
# CLI, tests, benchmarks) and runs the whole test suite, then a bounded fuzz pass: every libFuzzer
# harness for a few thousand inputs under ASan + UBSan (clang build in build-fuzz/, replaying
# fuzz/regressions/ first; docs/fuzzing.md). SHRM_FUZZ_RUNS sets the inputs per harness
# (default 2000; 0 skips the pass), SHRM_FUZZ_SECONDS caps each harness (default 20).
set -euo pipefail
cd "$(dirname "$0")/.."
bash scripts/install-deps.sh
bash scripts/check-format.sh
bash scripts/build.sh
ctest --test-dir "${SHRM_BUILD_DIR:-build}" --output-on-failure -j "$(nproc)"
if [ "${SHRM_FUZZ_RUNS:-2000}" != 0 ]; then
  bash scripts/fuzz.sh --runs "${SHRM_FUZZ_RUNS:-2000}" --max-time "${SHRM_FUZZ_SECONDS:-20}"
fi
