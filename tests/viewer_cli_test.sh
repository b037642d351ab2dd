#!/usr/bin/env bash
# Acceptance tests of `shrm-view` on the command line (docs/viewer.md): bad usage exits 2 with a
# message naming the option and writes nothing; bad input files exit 1; headless screenshots
# (--screenshot, FBO under Xvfb) of every registered mode, the difference view, the torus and an
# OBJ mesh, the in-frame overlay (--overlay), from an SHRM file (made with `shrm prefilter`) and computed on the fly, are written
# atomically (no temporary left) with the requested size; --bench-frames prints ms/frame.
#
# With SHRMD_BINARY (service builds) the SHRM is also computed by a loopback shrmd (--server).
#
# Usage: viewer_cli_test.sh SHRM_VIEW_BINARY REPO_ROOT [SHRM_BINARY [SHRMD_BINARY]]
# Needs a display: CTest runs it through tests/viewer_xvfb.sh (xvfb-run -a).
set -u

if [ $# -lt 2 ]; then
  echo "usage: $0 SHRM_VIEW_BINARY REPO_ROOT [SHRM_BINARY]" >&2
  exit 2
fi
VIEW=$1
ROOT=$2
SHRM=${3:-}
SHRMD=${4:-}
MAP="$ROOT/data/envmaps/courtyard.exr"
[ -x "$VIEW" ] || { echo "not executable: $VIEW" >&2; exit 2; }

TMP=$(mktemp -d "${TMPDIR:-/tmp}/shrm_viewer_cli_test.XXXXXX")
SHRMD_PID=
cleanup() {
  [ -n "$SHRMD_PID" ] && kill "$SHRMD_PID" 2>/dev/null && wait "$SHRMD_PID" 2>/dev/null
  rm -rf "$TMP"
}
trap cleanup EXIT
cd "$TMP" || exit 2

FAILURES=0
CHECKS=0
fail() {
  echo "FAIL: $*"
  FAILURES=$((FAILURES + 1))
}

# expect_error NAME RC REGEX ARGS...: exit code RC, stderr matching REGEX, no output file left.
expect_error() {
  local name=$1 want=$2 regex=$3
  shift 3
  CHECKS=$((CHECKS + 1))
  local dir="$TMP/cases/$name"
  mkdir -p "$dir"
  (cd "$dir" && "$VIEW" "$@") >"$dir.stdout" 2>"$dir.stderr"
  local rc=$?
  if [ "$rc" -ne "$want" ]; then
    fail "$name: exit code $rc, expected $want; stderr: $(head -c 300 "$dir.stderr")"
  elif ! grep -Eiq -- "$regex" "$dir.stderr"; then
    fail "$name: stderr does not match /$regex/: $(head -c 300 "$dir.stderr")"
  else
    echo "ok: $name (exit $rc): $(head -n 1 "$dir.stderr")"
  fi
  local left
  left=$(find "$dir" -mindepth 1 -print)
  [ -z "$left" ] || fail "$name: left behind: $left"
}

# PNG width and height from the IHDR chunk.
png_size() { od -An -tu1 -j16 -N8 "$1" | awk '{ printf "%d,%d", $1*16777216+$2*65536+$3*256+$4, $5*16777216+$6*65536+$7*256+$8 }'; }

# expect_image NAME FILE W,H ARGS...: exit 0, FILE written with that size, no temporary left.
expect_image() {
  local name=$1 file=$2 size=$3
  shift 3
  CHECKS=$((CHECKS + 1))
  "$VIEW" "$@" --screenshot "$file" --size "$size" >"$TMP/$name.stdout" 2>"$TMP/$name.stderr"
  local rc=$?
  if [ "$rc" -ne 0 ]; then
    fail "$name: exit code $rc; stderr: $(head -c 400 "$TMP/$name.stderr")"
    return
  fi
  if [ ! -s "$file" ]; then
    fail "$name: $file not written"
    return
  fi
  case "$file" in
    *.png)
      local got
      got=$(png_size "$file")
      [ "$got" = "$size" ] || fail "$name: $file is $got, expected $size"
      ;;
  esac
  local tmps
  tmps=$(find "$(dirname "$file")" -name '*.tmp-*' -print)
  [ -z "$tmps" ] || fail "$name: temporaries left: $tmps"
  echo "ok: $name: $(grep -m1 '^mode' "$TMP/$name.stdout")"
}

ENV=(--env "$MAP")
BRDF=(--brdf microfacet:sigma=0.3 --epsilon 0.05 --face-size 24)

# --- usage errors (exit 2), before any work --------------------------------------------------
expect_error no_source 2 'nothing to show' --screenshot a.png
# An empty value (an unset variable in a script) is refused, not taken as the option left out.
expect_error empty_screenshot 2 '--screenshot: an empty value' "${ENV[@]}" "${BRDF[@]}" --screenshot ""
expect_error env_without_brdf 2 'nothing to show' "${ENV[@]}" --screenshot a.png
expect_error bad_view 2 'view.*azimuth,elevation' "${ENV[@]}" "${BRDF[@]}" --view 10 --screenshot a.png
expect_error view_elevation 2 'elevation 95 is out of range' "${ENV[@]}" "${BRDF[@]}" --view 10,95 \
  --screenshot a.png
expect_error view_distance 2 'distance 0.5 is out of range' "${ENV[@]}" "${BRDF[@]}" \
  --view 10,5,0.5 --screenshot a.png
expect_error bad_size 2 'size must be W,H' "${ENV[@]}" "${BRDF[@]}" --size 0,10 --screenshot a.png
expect_error size_text 2 'size must be W,H' "${ENV[@]}" "${BRDF[@]}" --size big --screenshot a.png
expect_error mode_range 2 "^shrm-view: --mode: must be in \\[1, 9\\], got '12'$" "${ENV[@]}" "${BRDF[@]}" \
  --mode 12 --screenshot a.png
expect_error misspelt_option 2 "^shrm-view: unknown option --exposre \\(did you mean --exposure\\?\\)$" \
  "${ENV[@]}" "${BRDF[@]}" --exposre 2 --screenshot a.png
expect_error mode_unregistered 2 'mode 9 is not available' "${ENV[@]}" "${BRDF[@]}" --mode 9 \
  --screenshot a.png
expect_error bad_epsilon 2 'epsilon' "${ENV[@]}" "${BRDF[@]}" --epsilon 2 --screenshot a.png
expect_error bad_orders 2 'orders' "${ENV[@]}" "${BRDF[@]}" --orders 3 --screenshot a.png
expect_error bad_extension 2 'screenshot must end in' "${ENV[@]}" "${BRDF[@]}" --screenshot a.jpg
expect_error missing_folder 2 'does not exist' "${ENV[@]}" "${BRDF[@]}" --screenshot nodir/a.png
expect_error bad_mesh 2 'mesh must be sphere, torus' "${ENV[@]}" "${BRDF[@]}" --mesh cube \
  --screenshot a.png
expect_error truth_without_env 2 'ground truth.*--env' some.shrm.exr --mode 5 --screenshot a.png
expect_error unknown_option 2 'not expected|unknown' "${ENV[@]}" "${BRDF[@]}" --frobnicate --screenshot a.png
expect_error ref_width_odd 2 'ref-width must be even' "${ENV[@]}" "${BRDF[@]}" --ref-width 33 \
  --screenshot a.png
expect_error bench_and_shot 2 'exclusive' "${ENV[@]}" "${BRDF[@]}" --bench-frames 2 --screenshot a.png
expect_error bad_exposure 2 'exposure' "${ENV[@]}" "${BRDF[@]}" --exposure 1e9 --screenshot a.png
# --live (docs/viewer.md "Live"; the live screenshots are tests/viewer_live_cli_test.sh's).
LIVE_BRDF=(--brdf microfacet:sigma=0.2)
expect_error live_unknown_kind 2 'live' "${ENV[@]}" "${LIVE_BRDF[@]}" --live spin --screenshot a.png
expect_error live_step_without_live 2 'live-step needs --live' "${ENV[@]}" "${LIVE_BRDF[@]}" \
  --live-step 1 --screenshot a.png
expect_error sequence_without_live 2 'sequence needs --live' "${ENV[@]}" "${LIVE_BRDF[@]}" \
  --sequence a.exr --screenshot a.png
expect_error live_without_brdf 2 'live needs --brdf' "${ENV[@]}" --live rotate --screenshot a.png
expect_error live_rotate_without_env 2 'live rotate needs --env' "${LIVE_BRDF[@]}" --live rotate \
  --screenshot a.png
expect_error live_sequence_without_files 2 'needs --sequence' "${LIVE_BRDF[@]}" --live sequence \
  --screenshot a.png
expect_error live_sequence_with_env 2 'env is not used' "${ENV[@]}" "${LIVE_BRDF[@]}" \
  --live sequence --sequence "$MAP" --screenshot a.png
expect_error live_with_file 2 'does not show a file' some.shrm.exr "${ENV[@]}" "${LIVE_BRDF[@]}" \
  --live rotate --screenshot a.png
expect_error live_tolerance 2 'tolerance' "${ENV[@]}" "${LIVE_BRDF[@]}" --live rotate \
  --tolerance 0.01 --screenshot a.png
expect_error live_verify 2 'verify' "${ENV[@]}" "${LIVE_BRDF[@]}" --live rotate --verify 8 \
  --screenshot a.png
expect_error live_mode 2 'mode 1 or 2' "${ENV[@]}" "${LIVE_BRDF[@]}" --live rotate --mode 5 \
  --screenshot a.png
expect_error live_diff 2 'diff' "${ENV[@]}" "${LIVE_BRDF[@]}" --live rotate --diff --screenshot a.png
expect_error live_fps_rotate 2 'live-fps needs --live sequence' "${ENV[@]}" "${LIVE_BRDF[@]}" \
  --live rotate --live-fps 3 --screenshot a.png
expect_error live_speed_sequence 2 'live-speed applies to' "${LIVE_BRDF[@]}" --live sequence \
  --sequence "$MAP" --live-speed 3 --screenshot a.png
expect_error live_bad_step 2 'live-step' "${ENV[@]}" "${LIVE_BRDF[@]}" --live rotate --live-step 0 \
  --screenshot a.png
expect_error live_sky_with_env 2 'env is not used' "${ENV[@]}" "${LIVE_BRDF[@]}" --live sky \
  --screenshot a.png
expect_error live_sky_options 2 'need --live sky' "${ENV[@]}" "${LIVE_BRDF[@]}" --live rotate \
  --lat 10 --screenshot a.png
expect_error live_bad_date 2 'date must be a date' "${LIVE_BRDF[@]}" --live sky --date 2023-02-29 \
  --screenshot a.png
expect_error live_bad_time 2 'time must be a time' "${LIVE_BRDF[@]}" --live sky --time 25:00 \
  --screenshot a.png
expect_error live_bad_turbidity 2 'turbidity' "${LIVE_BRDF[@]}" --live sky --turbidity 1 \
  --screenshot a.png

# --- input errors (exit 1) --------------------------------------------------------------------
expect_error missing_shrm 1 'missing\.shrm\.exr' missing.shrm.exr --screenshot a.png
expect_error missing_env 1 'nope\.exr' --env nope.exr "${BRDF[@]}" --screenshot a.png
expect_error bad_brdf 1 "brdf 'microfacet'.*sigma" "${ENV[@]}" --brdf microfacet:sigma=-1 \
  --screenshot a.png
expect_error missing_obj 1 'nothing\.obj' "${ENV[@]}" "${BRDF[@]}" --mesh nothing.obj --screenshot a.png

# --- happy paths ------------------------------------------------------------------------------
mkdir out
expect_image mode1_computed out/m1.png 160,120 "${ENV[@]}" "${BRDF[@]}" --mode 1
expect_image mode2_computed out/m2.png 160,120 "${ENV[@]}" "${BRDF[@]}" --mode 2 --view -60,40,2.5
expect_image mode5_truth out/m5.png 96,72 "${ENV[@]}" "${BRDF[@]}" --mode 5 --ref-width 32
expect_image diff_view out/d1.png 96,72 "${ENV[@]}" "${BRDF[@]}" --mode 1 --diff --ref-width 32
grep -q 'diff: rel. RMS' "$TMP/diff_view.stdout" || fail "diff_view: no difference statistics"
expect_image torus out/torus.png 128,96 "${ENV[@]}" "${BRDF[@]}" --mesh torus --view 0,50
expect_image hdr_exr out/m1.exr 64,48 "${ENV[@]}" "${BRDF[@]}" --exposure 0
# --overlay: the text (6 lines, ~125 px high at 2x) is drawn into the top-left corner only: the
# bottom-right quarter stays the same (PNGs decoded with python3's zlib).
expect_image overlay_off out/ov0.png 480,360 "${ENV[@]}" "${BRDF[@]}" --exposure 0
expect_image overlay_on out/ov1.png 480,360 "${ENV[@]}" "${BRDF[@]}" --exposure 0 --overlay
CHECKS=$((CHECKS + 1))
if ov=$(python3 - out/ov0.png out/ov1.png <<'PY'
import struct, sys, zlib
def rows(path):
    data = open(path, "rb").read()
    pos, idat, w, h, ch = 8, b"", 0, 0, 0
    while pos < len(data):
        n, kind = struct.unpack(">I4s", data[pos:pos + 8])
        body = data[pos + 8:pos + 8 + n]
        if kind == b"IHDR":
            w, h, depth, color = struct.unpack(">IIBB", body[:10])
            assert depth == 8 and body[12] == 0, "8-bit non-interlaced only"
            ch = {0: 1, 2: 3, 4: 2, 6: 4}[color]
        elif kind == b"IDAT":
            idat += body
        pos += 12 + n
    raw, out, prev, stride = zlib.decompress(idat), [], bytearray(w * ch), w * ch
    for y in range(h):
        f, line = raw[y * (stride + 1)], bytearray(raw[y * (stride + 1) + 1:(y + 1) * (stride + 1)])
        for i in range(stride):
            a = line[i - ch] if i >= ch else 0
            b, c = prev[i], prev[i - ch] if i >= ch else 0
            if f == 1: line[i] = (line[i] + a) & 255
            elif f == 2: line[i] = (line[i] + b) & 255
            elif f == 3: line[i] = (line[i] + (a + b) // 2) & 255
            elif f == 4:
                p = a + b - c
                pa, pb, pc = abs(p - a), abs(p - b), abs(p - c)
                line[i] = (line[i] + (a if pa <= pb and pa <= pc else b if pb <= pc else c)) & 255
        out.append(bytes(line))
        prev = line
    return w, h, ch, out
w, h, ch, a = rows(sys.argv[1])
_, _, _, b = rows(sys.argv[2])
tl = sum(a[y][:w // 4 * ch] != b[y][:w // 4 * ch] for y in range(8, 40))
br = sum(a[y][w // 2 * ch:] != b[y][w // 2 * ch:] for y in range(h // 2, h))
print(f"{tl} of 32 top-left rows differ, {br} bottom-right rows differ")
sys.exit(0 if tl > 0 and br == 0 else 1)
PY
); then
  echo "ok: overlay: $ov"
else
  fail "overlay: the top-left must differ and the bottom-right quarter must not: $ov"
fi
cat >quad.obj <<'OBJ'
v -1 -1 0
v 1 -1 0
v 1 1 0
v -1 1 0
f 1 2 3 4
OBJ
expect_image obj_mesh out/obj.png 96,72 "${ENV[@]}" "${BRDF[@]}" --mesh quad.obj --view 0,0
if [ -n "$SHRM" ] && [ -x "$SHRM" ]; then
  CHECKS=$((CHECKS + 1))
  if "$SHRM" prefilter --env "$MAP" --brdf phong:s=64 --epsilon 0.03 --verify 0 --size 16 -o f.shrm.exr \
    --ktx2 f.shrm.ktx2 >/dev/null 2>&1; then
    expect_image from_file out/file.png 128,96 f.shrm.exr --mode 2
    grep -q 'phong:s=64' "$TMP/from_file.stdout" || fail "from_file: the file's shrm:brdf is not shown"
    # The same SHRM from its KTX2 container (docs/formats.md): the same image.
    expect_image from_ktx2 out/file_ktx2.png 128,96 f.shrm.ktx2 --mode 2
    cmp -s out/file.png out/file_ktx2.png || fail "from_ktx2: the image differs from the EXR file's"
    expect_image from_file_truth out/file5.png 64,48 f.shrm.exr --env "$MAP" --mode 5 --ref-width 32
  else
    fail "shrm prefilter failed: cannot make the SHRM file input"
  fi
fi
if [ -n "$SHRMD" ] && [ -x "$SHRMD" ]; then
  mkdir -p spool
  "$SHRMD" --listen 127.0.0.1:0 --spool-dir "$TMP/spool" --max-jobs 1 >shrmd.log 2>&1 &
  SHRMD_PID=$!
  PORT=
  for _ in $(seq 100); do
    PORT=$(grep -o '"port":"[0-9]*"' shrmd.log 2>/dev/null | grep -o '[0-9]\+' | head -n 1)
    [ -n "$PORT" ] && break
    sleep 0.1
  done
  if [ -z "$PORT" ]; then
    CHECKS=$((CHECKS + 1))
    fail "shrmd did not start: $(head -c 300 shrmd.log)"
  else
    expect_image server out/server.png 96,72 "${ENV[@]}" "${BRDF[@]}" --server "127.0.0.1:$PORT"
    grep -q "(server 127.0.0.1:$PORT)" "$TMP/server.stdout" || fail "server: not computed remotely"
  fi
fi

# The interactive window (visible under Xvfb) for a few frames: the SHRM arrives asynchronously
# while the loop runs, then the loop closes by itself.
CHECKS=$((CHECKS + 1))
if "$VIEW" "${ENV[@]}" "${BRDF[@]}" --size 96,72 --mode 2 --frames 40 >window.out 2>&1 &&
  grep -q 'SHRM microfacet:sigma=0.3 (embedded)' window.out; then
  echo "ok: interactive window, 40 frames"
else
  fail "interactive window: $(head -c 400 window.out)"
fi
CHECKS=$((CHECKS + 1))
if "$VIEW" "${ENV[@]}" "${BRDF[@]}" --bench-frames 2 --size 64,48 >bench.out 2>&1 &&
  grep -Eq 'mode 1 global-shrm +[0-9.]+ ms/frame' bench.out; then
  echo "ok: bench: $(grep -c ms/frame bench.out) modes timed"
else
  fail "bench: $(head -c 400 bench.out)"
fi

echo "$((CHECKS - FAILURES)) passed, $FAILURES failed"
[ "$FAILURES" -eq 0 ]
