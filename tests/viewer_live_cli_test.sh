#!/usr/bin/env bash
# `shrm-view --live` on the command line (docs/viewer.md "Live"), against an independent path:
# each live screenshot, taken with the deterministic clock (--live-step: frame k shows clock
# k x step and waits for its state's SHRM, so the image never depends on timing), equals the
# viewer's screenshot of the SHRM file `shrm prefilter --epsilon 0.03 --verify 0` writes for the
# same state (the map rotated by --rotate yaw,0,0; one sequence map; the sky `shrm sky` writes for
# the same date, time and place). Maps are the bundled ones box-filtered to 256 x 128, so each
# case takes a second or two. Also: the overlay's stages and rates on stdout, the frame benchmark,
# the interactive window, and bad inputs (exit 1, naming the file, before the window opens).
#
# Usage: viewer_live_cli_test.sh SHRM_VIEW SHRM VIEWER_LIVE_TOOL REPO_ROOT
# Needs a display: CTest runs it through tests/viewer_xvfb.sh (xvfb-run -a).
set -u

if [ $# -lt 4 ]; then
  echo "usage: $0 SHRM_VIEW SHRM VIEWER_LIVE_TOOL REPO_ROOT" >&2
  exit 2
fi
VIEW=$1
SHRM=$2
TOOL=$3
ROOT=$4
for b in "$VIEW" "$SHRM" "$TOOL"; do [ -x "$b" ] || { echo "not executable: $b" >&2; exit 2; }; done

# The same SHRM in the same GL program: the live frame's cube is Prefilter()'s bit for bit
# (tests/viewer_live_test.cc) and the file stores float32, so the pixels are equal exactly.
EXACT=0
# The background alone, live (the map turned by the shader, R^-1 d per pixel ray) against the
# unturned map seen from the camera turned the other way: the same directions through two float
# paths and bilinear lookups (measured: largest 4.6e-5 at 96 x 72, courtyard 256 x 128).
BACKGROUND_TOL=1e-3

TMP=$(mktemp -d "${TMPDIR:-/tmp}/shrm_viewer_live_test.XXXXXX")
trap 'rm -rf "$TMP"' EXIT
cd "$TMP" || exit 2

FAILURES=0
CHECKS=0
fail() {
  echo "FAIL: $*"
  FAILURES=$((FAILURES + 1))
}
# run NAME ARGS...: the command's exit code; its output in NAME.out.
run() {
  local name=$1
  shift
  "$@" >"$name.out" 2>&1
}
# same NAME A B TOL [MASK_KIND MASK]: A equals B within TOL (viewer_live_tool compare).
same() {
  local name=$1
  shift
  CHECKS=$((CHECKS + 1))
  if "$TOOL" compare "$@" >"$name.cmp" 2>&1; then
    echo "ok: $name: $(cat "$name.cmp")"
  else
    fail "$name: $(cat "$name.cmp")"
  fi
}

BRDF=microfacet:sigma=0.2
COMMON=(--brdf "$BRDF" --face-size 32 --size 96,72)
PREFILTER=(prefilter --brdf "$BRDF" --epsilon 0.03 --verify 0 --size 32)

mkdir seq empty
"$TOOL" downsample "$ROOT/data/envmaps/courtyard.exr" seq/0.exr 256 &&
  "$TOOL" downsample "$ROOT/data/envmaps/city.exr" seq/1.exr 256 &&
  "$TOOL" downsample "$ROOT/data/envmaps/forest.exr" seq/2.exr 256 || {
  echo "FAIL: cannot make the 256 x 128 maps"
  exit 1
}
MAP=seq/0.exr

# --- rotate: yaw 90 after 4 frames (3 steps of 1 s at 30 deg/s) -------------------------------
for mode in 1 2; do
  CHECKS=$((CHECKS + 1))
  if run rot$mode "$VIEW" --live rotate --env "$MAP" "${COMMON[@]}" --mode "$mode" \
    --live-speed 30 --live-step 1 --frames 4 --screenshot live_rot$mode.exr &&
    run pre_rot "$SHRM" "${PREFILTER[@]}" --env "$MAP" --rotate 90,0,0 -o rot90.shrm.exr &&
    run ref_rot$mode "$VIEW" rot90.shrm.exr --size 96,72 --mode "$mode" \
      --screenshot ref_rot$mode.exr; then
    echo "ok: rotate mode $mode: $(grep -o 'live rotate: yaw[^|]*' rot$mode.out)"
    # The mesh (where the file's screenshot, without --env, is not black): exactly equal.
    same "rotate mode $mode vs shrm prefilter --rotate 90,0,0" live_rot$mode.exr ref_rot$mode.exr \
      "$EXACT" nonzero ref_rot$mode.exr
  else
    fail "rotate mode $mode: $(tail -c 400 rot$mode.out pre_rot.out ref_rot$mode.out 2>/dev/null)"
  fi
done
# Not vacuous: the unrotated map's SHRM differs on the mesh.
CHECKS=$((CHECKS + 1))
if run pre0 "$SHRM" "${PREFILTER[@]}" --env "$MAP" -o rot0.shrm.exr &&
  run ref0 "$VIEW" rot0.shrm.exr --size 96,72 --screenshot ref_rot0.exr &&
  ! "$TOOL" compare live_rot1.exr ref_rot0.exr 0.01 nonzero ref_rot0.exr >differ.cmp 2>&1; then
  echo "ok: yaw 0 differs from yaw 90: $(cat differ.cmp)"
else
  fail "yaw 0 does not differ from yaw 90: $(cat differ.cmp 2>/dev/null)"
fi
# The background turns with the lighting: turning the map by yaw 90 is turning the camera by -90
# (the default view 30,20,3 -> -60,20,3) over the unturned map.
CHECKS=$((CHECKS + 1))
if run bg "$VIEW" rot0.shrm.exr --env "$MAP" --size 96,72 --view -60,20,3 --screenshot ref_bg.exr; then
  same "background turned by yaw 90" live_rot1.exr ref_bg.exr "$BACKGROUND_TOL" zero ref_rot1.exr
else
  fail "background reference: $(tail -c 300 bg.out)"
fi

# --- sequence: a folder at 2 frames/s; frame 3 (clock 1.0 s) shows 2.exr -----------------------
CHECKS=$((CHECKS + 1))
if run seq "$VIEW" --live sequence --sequence seq "${COMMON[@]}" --live-fps 2 --live-step 0.5 \
  --frames 3 --screenshot live_seq.exr &&
  run pre_seq "$SHRM" "${PREFILTER[@]}" --env seq/2.exr -o seq2.shrm.exr &&
  run ref_seq "$VIEW" seq2.shrm.exr --env seq/2.exr --size 96,72 --screenshot ref_seq.exr; then
  echo "ok: sequence: $(grep -o 'live sequence: frame[^|]*' seq.out)"
  grep -q 'live sequence: frame 3/3 2.exr' seq.out || fail "sequence: not frame 3/3 2.exr"
  # Mesh and background: the same SHRM, the same map.
  same "sequence frame 2.exr vs shrm prefilter" live_seq.exr ref_seq.exr "$EXACT"
else
  fail "sequence: $(tail -c 400 seq.out pre_seq.out ref_seq.out 2>/dev/null)"
fi
# Files as given, in the order given: the first frame is city.
CHECKS=$((CHECKS + 1))
if run seq_files "$VIEW" --live sequence --sequence seq/1.exr seq/0.exr "${COMMON[@]}" \
  --live-step 0.5 --screenshot live_seq1.exr &&
  grep -q 'live sequence: frame 1/2 1.exr' seq_files.out; then
  echo "ok: sequence of files: $(grep -o 'live sequence: frame[^|]*' seq_files.out)"
else
  fail "sequence of files: $(tail -c 400 seq_files.out)"
fi

# --- mode 6: the split-sum of the live lighting (the session's chain) --------------------------
# Frame 3 of the sequence (2.exr) in mode 6 against the fixed map's mode 6 (its chain computed by
# the viewer): the same chain bit for bit (tests/viewer_live_test.cc), so the same pixels.
GGX=ggx:alpha=0.3
CHECKS=$((CHECKS + 1))
if run ss "$VIEW" --live sequence --sequence seq --brdf "$GGX" --face-size 32 --size 96,72 \
  --mode 6 --live-fps 2 --live-step 0.5 --frames 3 --screenshot live_ss.exr &&
  run ref_ss "$VIEW" --env seq/2.exr --brdf "$GGX" --face-size 32 --size 96,72 --mode 6 \
    --screenshot ref_ss.exr; then
  grep -q 'live sequence: frame 3/3 2.exr' ss.out || fail "mode 6 sequence: not frame 3/3 2.exr"
  same "mode 6 (split-sum) of sequence frame 2.exr vs the fixed map's" live_ss.exr ref_ss.exr "$EXACT"
else
  fail "mode 6 live: $(tail -c 400 ss.out ref_ss.out 2>/dev/null)"
fi
CHECKS=$((CHECKS + 1))
if ! run ss_phong "$VIEW" --live sequence --sequence seq "${COMMON[@]}" --mode 6 \
  --screenshot never.exr && grep -q 'shades GGX' ss_phong.out && [ ! -e never.exr ]; then
  echo "ok: --live --mode 6 with a non-GGX BRDF refused: $(tail -n 1 ss_phong.out)"
else
  fail "--live --mode 6 with $BRDF: $(tail -c 300 ss_phong.out)"
fi

# --- sky: 06:00 + 3 steps of 1 s at 2 h/s = 12:00, as `shrm sky` renders it --------------------
SKY=(--date 2024-06-21 --lat 37.87 --lon -122.27 --turbidity 3)
CHECKS=$((CHECKS + 1))
if run sky "$VIEW" --live sky "${SKY[@]}" --time 06:00 "${COMMON[@]}" --live-speed 2 \
  --live-step 1 --frames 4 --screenshot live_sky.exr &&
  run shrm_sky "$SHRM" sky "${SKY[@]}" --time 12:00 --width 256 -o sky.exr &&
  run pre_sky "$SHRM" "${PREFILTER[@]}" --env sky.exr -o sky.shrm.exr &&
  run ref_sky "$VIEW" sky.shrm.exr --env sky.exr --size 96,72 --screenshot ref_sky.exr; then
  echo "ok: sky: $(grep -o 'live sky: day[^|]*' sky.out)"
  grep -q 'live sky: day 173 12:00' sky.out || fail "sky: not day 173 12:00"
  same "sky at 12:00 vs shrm sky + shrm prefilter" live_sky.exr ref_sky.exr "$EXACT"
else
  fail "sky: $(tail -c 400 sky.out shrm_sky.out pre_sky.out ref_sky.out 2>/dev/null)"
fi

# --- the overlay: every stage in ms, the rates, (F_B, P_B) -------------------------------------
CHECKS=$((CHECKS + 1))
missing=
for want in 'ms: brdf [0-9.]+ lighting [0-9.]+ analysis [0-9.]+ synthesis [0-9.]+' \
  'compute [0-9.]+ convert [0-9.]+' 'live [0-9.]+ frames/s, render [0-9.]+ frames/s, dropped [0-9]+ of [0-9]+' \
  '\(F_B, P_B\) = \([0-9]+, [0-9]+\)'; do
  grep -Eq "$want" rot1.out || missing="$missing /$want/"
done
if [ -z "$missing" ]; then
  echo "ok: overlay: $(grep -Eo 'ms: brdf[^|]*' rot1.out)"
else
  fail "overlay: missing$missing in: $(head -c 600 rot1.out)"
fi
CHECKS=$((CHECKS + 1))
if run ov "$VIEW" --live rotate --env "$MAP" "${COMMON[@]}" --live-step 1 --overlay \
  --screenshot ov.png && [ -s ov.png ]; then
  echo "ok: overlay drawn into a PNG"
else
  fail "overlay PNG: $(tail -c 300 ov.out)"
fi

# --- the frame benchmark and the interactive window (wall clock) -------------------------------
CHECKS=$((CHECKS + 1))
if run bench "$VIEW" --live rotate --env "$MAP" "${COMMON[@]}" --bench-frames 10 &&
  grep -Eq 'live frames computed \([0-9.]+ frames/s\)' bench.out &&
  grep -Eq 'mean ms per shown frame .*synthesis [0-9.]+ \| compute' bench.out; then
  echo "ok: bench: $(grep -Eo '[0-9]+ frames rendered.*' bench.out)"
else
  fail "bench: $(tail -c 400 bench.out)"
fi
CHECKS=$((CHECKS + 1))
if run window "$VIEW" --live sequence --sequence seq "${COMMON[@]}" --mode 2 --frames 30; then
  echo "ok: interactive window, 30 frames"
else
  fail "interactive window: $(tail -c 400 window.out)"
fi

# --- bad inputs: exit 1 naming the file, before the window -------------------------------------
# expect1 NAME REGEX ARGS...
expect1() {
  local name=$1 regex=$2
  shift 2
  CHECKS=$((CHECKS + 1))
  "$VIEW" "$@" >"$name.out" 2>"$name.err"
  local rc=$?
  if [ "$rc" -ne 1 ]; then
    fail "$name: exit code $rc, expected 1: $(head -c 300 "$name.err")"
  elif ! grep -Eq -- "$regex" "$name.err"; then
    fail "$name: stderr does not match /$regex/: $(head -c 300 "$name.err")"
  else
    echo "ok: $name (exit 1): $(head -n 1 "$name.err")"
  fi
}
printf 'not an exr' >bad.exr
expect1 missing_frame 'missing\.exr' --live sequence --sequence seq/0.exr missing.exr "${COMMON[@]}" \
  --screenshot x.png
expect1 corrupt_frame 'bad\.exr' --live sequence --sequence seq/0.exr bad.exr "${COMMON[@]}" \
  --screenshot x.png
expect1 empty_folder 'empty.*has no \.exr files' --live sequence --sequence empty "${COMMON[@]}" \
  --screenshot x.png
expect1 missing_rotate_map 'nope\.exr' --live rotate --env nope.exr "${COMMON[@]}" --screenshot x.png
[ -e x.png ] && fail "an input error wrote x.png"

echo "$((CHECKS - FAILURES)) passed, $FAILURES failed"
[ "$FAILURES" -eq 0 ]
