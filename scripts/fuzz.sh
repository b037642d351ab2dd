#!/usr/bin/env bash
# Builds the libFuzzer harnesses (clang, ASan + UBSan, build-fuzz/) and runs every one of them
# (docs/fuzzing.md).
#
#   scripts/fuzz.sh --runs N        N inputs per harness (the test command's bounded pass); new
#                                   inputs go to a scratch folder, the corpora stay as they are;
#                                   --max-time S stops a slow harness after S seconds
#   scripts/fuzz.sh --time SECONDS  SECONDS per harness, then the new inputs that add coverage
#                                   are merged into fuzz/corpus/<harness> (-merge=1)
#   --only a,b     these harnesses only        --no-build   use the existing build-fuzz
#   --build-only   build and stop              --summary F  summary file (default
#                                                           build-fuzz/fuzz-summary.txt)
#
# Before fuzzing, every input saved under fuzz/regressions/<harness>/ is replayed. Any crash, leak,
# timeout, out-of-memory or sanitizer report fails the script; the input that caused it is saved
# under fuzz/regressions/<harness>/ (commit it with the fix). One summary line per harness (inputs
# executed, crashes, slowest input, coverage cov/ft) goes to stdout and to the summary file; inputs
# slower than 10 s are kept under build-fuzz/fuzz-slow/<harness>/ for a look.
set -euo pipefail
cd "$(dirname "$0")/.."
ROOT=$PWD
BUILD_DIR=${SHRM_FUZZ_BUILD_DIR:-build-fuzz}
JOBS=${SHRM_JOBS:-2}
HARNESSES=(image brdf_spec brdf_table merl shrm_file shrm_ktx2 batch_manifest config_file auth
           request ktx_roundtrip gltf_roundtrip)
RUNS=""
TIME=""
MAX_TIME=""
ONLY=""
BUILD=1
BUILD_ONLY=0
SUMMARY=""
while [ $# -gt 0 ]; do
  case "$1" in
    --runs) RUNS=$2; shift 2 ;;
    --time) TIME=$2; shift 2 ;;
    --max-time) MAX_TIME=$2; shift 2 ;;
    --only) ONLY=$2; shift 2 ;;
    --no-build) BUILD=0; shift ;;
    --build-only) BUILD_ONLY=1; shift ;;
    --summary) SUMMARY=$2; shift 2 ;;
    -h|--help) sed -n '2,20p' "$0"; exit 0 ;;
    *) echo "fuzz.sh: unknown argument $1" >&2; exit 2 ;;
  esac
done
if [ -n "$ONLY" ]; then IFS=, read -r -a HARNESSES <<<"$ONLY"; fi
if [ -z "$RUNS" ] && [ -z "$TIME" ]; then RUNS=2000; fi
SUMMARY=${SUMMARY:-$BUILD_DIR/fuzz-summary.txt}

if [ "$BUILD" -eq 1 ]; then
  # Release with debug info, at -O1 (libFuzzer's usual level; the build dominates the test
  # command's pass) with line tables for the sanitizers' stack traces. Only what the harnesses
  # link is built.
  flags="-O1 -gline-tables-only -DNDEBUG"
  cmake -S . -B "$BUILD_DIR" -G Ninja -DCMAKE_BUILD_TYPE=RelWithDebInfo \
    -DCMAKE_CXX_FLAGS_RELWITHDEBINFO="$flags" -DCMAKE_C_FLAGS_RELWITHDEBINFO="$flags" \
    -DCMAKE_C_COMPILER=clang \
    -DCMAKE_CXX_COMPILER=clang++ -DSHRM_FUZZ=ON -DSHRM_BUILD_TESTS=OFF -DSHRM_BUILD_BENCH=OFF \
    -DSHRM_BUILD_VIEWER=OFF -DSHRM_BENCH_LIBSHARP=OFF >/dev/null
  cmake --build "$BUILD_DIR" -j "$JOBS" --target shrm_fuzzers fuzz_seed_writer
fi
[ "$BUILD_ONLY" -eq 1 ] && exit 0

export ASAN_OPTIONS=${ASAN_OPTIONS:-detect_leaks=1:allocator_may_return_null=1:handle_abort=1}
export UBSAN_OPTIONS=${UBSAN_OPTIONS:-print_stacktrace=1:halt_on_error=1}
export LSAN_OPTIONS=${LSAN_OPTIONS:-suppressions=$ROOT/fuzz/lsan.supp:print_suppressions=0}
SCRATCH=$(mktemp -d "${TMPDIR:-/tmp}/shrm-fuzz.XXXXXX")
trap 'rm -rf "$SCRATCH"' EXIT
mkdir -p "$(dirname "$SUMMARY")"
: >"$SUMMARY"
failed=()

# Per-harness limits: inputs up to 64 KiB for the image readers (seeds are a few KiB), 4 KiB
# otherwise; 60 s per input (a hang is a finding); 2.5 GiB of RSS.
max_len() { case "$1" in image|shrm_file|brdf_table) echo 65536 ;; *) echo 4096 ;; esac; }

for h in "${HARNESSES[@]}"; do
  bin="$BUILD_DIR/fuzz/fuzz_$h"
  [ -x "$bin" ] || { echo "fuzz.sh: $bin not built" >&2; exit 2; }
  corpus="fuzz/corpus/$h"
  regressions="fuzz/regressions/$h"
  mkdir -p "$corpus" "$SCRATCH/$h/new" "$SCRATCH/$h/artifacts"
  opts=(-print_final_stats=1 -timeout=60 -rss_limit_mb=2560 -max_len="$(max_len "$h")"
        -artifact_prefix="$SCRATCH/$h/artifacts/")
  [ -f "fuzz/dict/$h.dict" ] && opts+=(-dict="fuzz/dict/$h.dict")
  log="$SCRATCH/$h/log"
  status=0
  # 1. The saved regressions, each run once.
  if [ -d "$regressions" ] && [ -n "$(ls -A "$regressions")" ]; then
    "$bin" "${opts[@]}" "$regressions"/* >"$SCRATCH/$h/regressions.log" 2>&1 || {
      status=$?
      echo "fuzz.sh: $h: a regression input fails again:" >&2
      tail -40 "$SCRATCH/$h/regressions.log" >&2
    }
  fi
  # 2. Fuzzing, from the corpus; new inputs go to the scratch folder.
  if [ "$status" -eq 0 ]; then
    if [ -n "$TIME" ]; then run=(-max_total_time="$TIME"); else run=(-runs="$RUNS"); fi
    [ -n "$MAX_TIME" ] && [ -z "$TIME" ] && run+=(-max_total_time="$MAX_TIME")
    dirs=("$SCRATCH/$h/new" "$corpus")
    [ -d "$regressions" ] && dirs+=("$regressions")  # the found inputs seed the search too
    "$bin" "${opts[@]}" "${run[@]}" "${dirs[@]}" >"$log" 2>&1 || status=$?
  fi
  # 3. Crashes, leaks, timeouts and OOMs become regression inputs.
  crashes=0
  for a in "$SCRATCH/$h/artifacts"/*; do
    [ -e "$a" ] || continue
    case "$(basename "$a")" in
      slow-unit-*) mkdir -p "$BUILD_DIR/fuzz-slow/$h"; cp "$a" "$BUILD_DIR/fuzz-slow/$h/"; continue ;;
    esac
    mkdir -p "$regressions"
    cp "$a" "$regressions/"
    crashes=$((crashes + 1))
  done
  if [ "$status" -ne 0 ]; then
    [ "$crashes" -eq 0 ] && crashes=1
    failed+=("$h")
    [ -f "$log" ] && grep -E -A30 "ERROR: |runtime error|fuzz: check failed|==ERROR|deadly signal" "$log" \
      | head -60 >&2 || true
  elif [ -n "$TIME" ]; then
    # 4. Long runs keep the inputs that add coverage (the corpus stays minimal).
    "$bin" -merge=1 -max_len="$(max_len "$h")" "$corpus" "$SCRATCH/$h/new" >"$SCRATCH/$h/merge.log" 2>&1 \
      || echo "fuzz.sh: $h: merge failed (see the log)" >&2
  fi
  # 5. The summary line, from -print_final_stats and the last status line.
  stat() { grep -E "^stat::$1:" "$log" 2>/dev/null | tail -1 | awk '{print $2}'; }
  execs=$(stat number_of_executed_units)
  slowest=$(stat slowest_unit_time_sec)
  rss=$(stat peak_rss_mb)
  covline=$(grep -E "^#[0-9]+" "$log" 2>/dev/null | grep -E "cov: " | tail -1 || true)
  cov=$(sed -nE 's/.* cov: ([0-9]+).*/\1/p' <<<"$covline")
  ft=$(sed -nE 's/.* ft: ([0-9]+).*/\1/p' <<<"$covline")
  line=$(printf '%-15s inputs %9s  crashes %d  slowest %ss  cov %s  ft %s  peak_rss %sMB  corpus %d files' \
    "$h" "${execs:-?}" "$crashes" "${slowest:-?}" "${cov:-?}" "${ft:-?}" "${rss:-?}" \
    "$(find "$corpus" -type f | wc -l)")
  echo "$line" | tee -a "$SUMMARY"
  mkdir -p "$BUILD_DIR/fuzz-logs"
  cp "$log" "$BUILD_DIR/fuzz-logs/$h.log" 2>/dev/null || true
done

if [ ${#failed[@]} -gt 0 ]; then
  echo "fuzz.sh: FAILED: ${failed[*]} (inputs saved under fuzz/regressions/; logs in $BUILD_DIR/fuzz-logs/)" \
    | tee -a "$SUMMARY" >&2
  exit 1
fi
echo "fuzz.sh: all ${#HARNESSES[@]} harnesses passed (summary: $SUMMARY)"
