#!/usr/bin/env bash
# The test suite under AddressSanitizer + UndefinedBehaviorSanitizer (g++; docs/server.md
# "Hardening"): a separate build (build-asan, -O1 with debug info, no viewer, no benchmarks) and
# every CTest test except the ones that drive whole programs from the shell or a browser (cli,
# batch, engines, install, deploy: the same code paths run in the unit tests, and their own
# timeouts assume full-speed binaries), and MemoryAdmissionTest (it bounds the daemon's resident
# memory, which AddressSanitizer's shadow memory and quarantine inflate by design; the budget's
# own accounting, MemoryBudgetTest, runs). Any sanitizer report fails the test that triggers it
# (halt_on_error / abort_on_error).
#
#   scripts/sanitize.sh [CTEST ARGS...]   the whole suite (about 2 hours on 2 cores)
#   scripts/sanitize.sh --service         only the service's tests (the daemon, its client, the
#                                         blob store, the decoder sandbox, idle clients, retries):
#                                         the targets they need are built, nothing else
set -euo pipefail
cd "$(dirname "$0")/.."
BUILD_DIR=${SHRM_SANITIZE_BUILD_DIR:-build-asan}
FLAGS="-fsanitize=address,undefined -fno-omit-frame-pointer -fno-sanitize-recover=undefined"
cmake -S . -B "$BUILD_DIR" -G Ninja -DCMAKE_BUILD_TYPE=RelWithDebInfo \
  -DCMAKE_CXX_FLAGS_RELWITHDEBINFO="-O1 -g" -DCMAKE_C_FLAGS_RELWITHDEBINFO="-O1 -g" \
  -DCMAKE_CXX_FLAGS="$FLAGS" -DCMAKE_C_FLAGS="$FLAGS" \
  -DCMAKE_EXE_LINKER_FLAGS="-fsanitize=address,undefined" \
  -DCMAKE_SHARED_LINKER_FLAGS="-fsanitize=address,undefined" \
  -DCMAKE_MODULE_LINKER_FLAGS="-fsanitize=address,undefined" \
  -DSHRM_BUILD_BENCH=OFF -DSHRM_BUILD_VIEWER=OFF -DSHRM_NATIVE=OFF
SERVICE_TESTS=(service_test service_ops_test service_load_test decoder_sandbox_test
  blob_store_test idle_clients_test client_retry_test status_details_test memory_admission_test)
if [ "${1:-}" = --service ]; then
  shift
  cmake --build "$BUILD_DIR" -j "${SHRM_JOBS:-$(nproc)}" --target "${SERVICE_TESTS[@]}"
  set -- -R '^(ServiceTest|ServiceOpsTest|ServiceLoadTest|AuthTest|ConfigFileTest|DecoderSandboxTest|BlobStoreTest|IdleClientsTest|ClientRetryTest|ClientDecisions|StatusDetails|MemoryBudgetTest|MemoryAdmissionInProcessTest)\.' "$@"
else
  cmake --build "$BUILD_DIR" -j "${SHRM_JOBS:-$(nproc)}"
fi
export ASAN_OPTIONS="abort_on_error=1:detect_leaks=1:strict_string_checks=1:detect_stack_use_after_return=1"
export UBSAN_OPTIONS="print_stacktrace=1:halt_on_error=1"
ctest --test-dir "$BUILD_DIR" --output-on-failure -j "$(nproc)" \
  -E '^(cli_test|batch_test|engines_test|install_test|deploy_test|MemoryAdmissionTest\..*)$' "$@"
