#!/usr/bin/env bash
# `shrm ibl` sets read by real third-party consumers (docs/engines.md):
#   1. ktx-parse (npm) reads every KTX2 file of sets in all four formats: header, level sizes,
#      DFD, key/value data against ibl.json and the specifications; decoded values against the
#      inputs (a constant map; a map with patches at +X, +Y, -Z); radiance_sh9 against the SH of
#      the input, and its conversion to three.js's SH basis against three's own code; a mirrored
#      and an upside-down copy of a set must fail (negative controls);
#   2. three.js in headless Chromium (Debian's chromium, WebGL2 on SwiftShader, playwright-core)
#      reads every texel back through GL's cube-map selection, renders the cube on a sphere (which
#      side is +X), three's own IBL path and a LightProbe from radiance_sh9;
#   3. gltf-validator and Babylon.js (its glTF loader's EXT_lights_image_based) read ibl.glb
#      (--containers gltf): no validation errors, the RGBD faces = specular.ktx2, Babylon's specular
#      term = a node render of its shading, the red patch on the +X side (a mirrored copy fails);
#   4. Filament (WASM) in the same browser loads the KTX1 files (--containers ktx1) as it loads
#      cmgen's and renders spheres: white furnace, orientation, CPU render of its shading;
#   5. the shipped WGSL (shaders/wgsl/shrm.wgsl) in the same browser's WebGPU evaluates SHRMs
#      written with `shrm prefilter --ktx2` (ktx-parse reads them) = shrm's CPU evaluation;
#   6. the visual report of `shrm prefilter --report-html` opens in the same browser without
#      console errors or network requests, its plots drawn.
# npm packages are pinned in tests/engines/package-lock.json and installed with `npm ci` into
# CACHE_DIR/engines-node (reused while the lockfile is unchanged); nothing else needs a network.
# The maps are made here with oiiotool; screenshots land in CACHE_DIR/engines-out.
#
# Usage: engines_test.sh SHRM REPO_ROOT [CACHE_DIR]   (CTest: engines_test)
set -euo pipefail

if [ $# -lt 2 ] || [ $# -gt 3 ]; then
  echo "usage: $0 SHRM REPO_ROOT [CACHE_DIR]" >&2
  exit 2
fi
SHRM=$(readlink -f "$1")
ROOT=$(readlink -f "$2")
[ -x "$SHRM" ] || { echo "not executable: $SHRM" >&2; exit 2; }
TMP=$(mktemp -d "${TMPDIR:-/tmp}/shrm_engines_test.XXXXXX")
trap 'rm -rf "$TMP"' EXIT
CACHE=$(readlink -f "${3:-$TMP/cache}")
CHROMIUM=${CHROMIUM:-/usr/bin/chromium}
START=$(date +%s)

# Missing tools are install errors (scripts/install-deps.sh), never skips.
missing=()
command -v node >/dev/null || missing+=(node)
command -v npm >/dev/null || missing+=(npm)
command -v oiiotool >/dev/null || missing+=("oiiotool (openimageio-tools)")
[ -x "$CHROMIUM" ] || missing+=("$CHROMIUM (chromium)")
if [ ${#missing[@]} -gt 0 ]; then
  echo "FAIL: missing ${missing[*]}: run scripts/install-deps.sh"
  exit 1
fi

# --- npm packages (ktx-parse, three, playwright-core) -------------------------------------------
NODE_DIR="$CACHE/engines-node"
mkdir -p "$NODE_DIR"
cp "$ROOT"/tests/engines/package.json "$ROOT"/tests/engines/package-lock.json \
  "$ROOT"/tests/engines/*.mjs "$ROOT"/tests/engines/*.js "$ROOT"/tests/engines/*.html "$NODE_DIR/"
stamp=$(sha256sum "$NODE_DIR/package-lock.json" | cut -d' ' -f1)
if [ -d "$NODE_DIR/node_modules" ] && [ "$(cat "$NODE_DIR/.stamp" 2>/dev/null)" = "$stamp" ]; then
  echo "PASS: npm packages cached in $NODE_DIR (package-lock.json unchanged)"
elif (cd "$NODE_DIR" && rm -rf node_modules && npm ci --no-audit --no-fund --ignore-scripts) \
  >"$TMP/npm.log" 2>&1; then
  echo "$stamp" >"$NODE_DIR/.stamp"
  echo "PASS: npm ci ($(cd "$NODE_DIR" && node -e '
    const l = require("./package-lock.json").packages;
    console.log(Object.keys(require("./package.json").dependencies)
      .map((n) => n + "@" + l["node_modules/" + n].version).join(", "))'))"
else
  echo "FAIL: npm ci in $NODE_DIR failed (network or registry?):"
  tail -n 20 "$TMP/npm.log"
  exit 1
fi
for p in ktx-parse three playwright-core filament; do
  [ -f "$NODE_DIR/node_modules/$p/package.json" ] ||
    { echo "FAIL: $NODE_DIR/node_modules/$p missing after npm ci"; exit 1; }
done

# --- input maps (lat-long, docs/conventions.md: u = 0.75 is +X, u = 0.5 is -Z, top row +Y) -------
MAPS="$TMP/maps"
mkdir -p "$MAPS"
oiiotool --pattern constant:color=1,1,1 64x32 3 -d float -o "$MAPS/white.exr"
# 256 x 128: grey 0.05; red 8 in columns 184..199 x rows 40..55 (around u = 0.75: +X, 11 to 34
# degrees up); green 8 in rows 0..7 (+Y); blue 8 in columns 120..135 x rows 56..71 (u = 0.5: -Z).
# tests/engines/ktx_cube.mjs PATCHES describes the same map.
oiiotool --pattern constant:color=0.05,0.05,0.05 256x128 3 \
  --fill:color=8,0,0 16x16+184+40 --fill:color=0,8,0 256x8+0+0 --fill:color=0,0,8 16x16+120+56 \
  -d float -o "$MAPS/patches.exr"

# --- sets ------------------------------------------------------------------------------------------
SETS="$TMP/sets"
mkdir -p "$SETS"
FAILURES=0
make_set() { # name, map, shrm ibl options...
  local name=$1 map=$2
  shift 2
  if "$SHRM" ibl --env "$MAPS/$map" -o "$SETS/$name" --threads 2 "$@" >"$TMP/$name.log" 2>&1; then
    echo "PASS: shrm ibl --env $map $* -> $name"
  else
    echo "FAIL: shrm ibl --env $map $*:"
    cat "$TMP/$name.log"
    FAILURES=$((FAILURES + 1))
  fi
}
make_set patches-rgba16f patches.exr --size 32 --sheen --preset gltf
for f in rgba32f r11g11b10f rgb9e5; do
  make_set "patches-$f" patches.exr --size 16 --format "$f" --verify 0
done
# The constant map through the presets and an explicit roughness list (shrm:roughness vs ibl.json).
make_set white-rgba16f white.exr --size 16 --format rgba16f --sheen --verify 0
make_set white-rgba32f white.exr --size 16 --format rgba32f --sheen --preset gltf --verify 0
make_set white-r11g11b10f white.exr --size 16 --format r11g11b10f --roughness 0,0.3,0.6,1 --verify 0
make_set white-rgb9e5 white.exr --size 16 --format rgb9e5 --sheen --levels 3 --verify 0
# A real map (lookups and the file checks; radiance_sh9 only loosely against the cube).
COURTYARD="$ROOT/data/envmaps/courtyard.exr"
[ -f "$COURTYARD" ] || { echo "FAIL: missing bundled map $COURTYARD"; exit 1; }
cp "$COURTYARD" "$MAPS/"
# Its pixels for the node checks (radiance_sh9, irradiance): downsized to 256 x 128, as text.
oiiotool "$COURTYARD" --resize 256x128 -d float -o "$MAPS/courtyard256.exr"
oiiotool --dumpdata "$MAPS/courtyard256.exr" >"$MAPS/courtyard256.txt"
make_set courtyard-rgba16f courtyard.exr --size 32 --preset gltf --verify 0
[ "$FAILURES" -eq 0 ] || { echo "FAIL: $FAILURES set(s) not made"; exit 1; }

echo "(sets made: $(($(date +%s) - START)) s)"

# --- 1. ktx-parse -----------------------------------------------------------------------------------
run_node() { # log name, script, args...
  local log="$TMP/$1.out"
  shift
  if (cd "$NODE_DIR" && node "$@") >"$log" 2>&1; then :; else
    grep -q '^FAIL' "$log" || echo "FAIL: node $* exited non-zero" >>"$log"
  fi
  cat "$log"
  FAILURES=$((FAILURES + $(grep -c '^FAIL' "$log" || true)))
}
run_node ktx-patches16 check_ktx2.mjs "$SETS/patches-rgba16f" --patches
for f in rgba32f r11g11b10f rgb9e5; do
  run_node "ktx-patches-$f" check_ktx2.mjs "$SETS/patches-$f" --patches
done
for f in rgba16f rgba32f r11g11b10f rgb9e5; do
  run_node "ktx-white-$f" check_ktx2.mjs "$SETS/white-$f" --constant 1,1,1
done
run_node ktx-courtyard check_ktx2.mjs "$SETS/courtyard-rgba16f" --map "$MAPS/courtyard256.txt"

# Negative controls: a mirrored and an upside-down copy of the patches set must fail the
# orientation checks (which shows that they can fail).
for how in mirror-x flip-rows; do
  run_node "break-$how" break_set.mjs "$SETS/patches-rgba16f" "$SETS/broken-$how" "$how"
  if (cd "$NODE_DIR" && node check_ktx2.mjs "$SETS/broken-$how" --patches) >"$TMP/neg-$how.log" 2>&1; then
    echo "FAIL: negative control $how: check_ktx2.mjs --patches accepted it" | tee -a "$TMP/break-$how.out"
    FAILURES=$((FAILURES + 1))
  elif grep -q '^FAIL: patches: specular level 0 holds' "$TMP/neg-$how.log"; then
    echo "PASS: negative control $how: check_ktx2.mjs rejects it: $(grep '^FAIL: patches' "$TMP/neg-$how.log" | head -n 1 | cut -c7-)" |
      tee -a "$TMP/break-$how.out"
  else
    echo "FAIL: negative control $how: check_ktx2.mjs failed for another reason:" | tee -a "$TMP/break-$how.out"
    grep '^FAIL' "$TMP/neg-$how.log" || tail -n 5 "$TMP/neg-$how.log"
    FAILURES=$((FAILURES + 1))
  fi
done

echo "(ktx-parse checks done: $(($(date +%s) - START)) s)"

# --- 2. three.js in Chromium ------------------------------------------------------------------------
OUT="$CACHE/engines-out"
rm -rf "$OUT"
CHROMIUM="$CHROMIUM" run_node browser run_browser.mjs "$OUT" "$SETS/patches-rgba16f" \
  "$SETS/patches-rgba32f" "$SETS/patches-r11g11b10f" "$SETS/patches-rgb9e5" "$SETS/courtyard-rgba16f" \
  --broken "$SETS/broken-mirror-x" "$SETS/broken-flip-rows" --probe "$SETS/courtyard-rgba16f"

# --- 3. Babylon.js and gltf-validator ----------------------------------------------------------
# ibl.glb (EXT_lights_image_based) of sets made with --containers ktx2,gltf: gltf-validator, the RGBD
# faces against specular.ktx2, Babylon's render against a node render of its shading, orientation
# with a mirrored negative control (tests/engines/babylon_run.mjs, docs/engines.md).
# The white map makes the same scene: Babylon's environment-BRDF factor per pixel (a white furnace).
before=$FAILURES
make_set white-gltf white.exr --size 32 --preset babylon --levels 4 --containers ktx2,gltf --verify 0
make_set patches-gltf patches.exr --size 32 --preset babylon --levels 4 --containers ktx2,gltf --verify 0
make_set courtyard-gltf courtyard.exr --size 32 --preset babylon --levels 4 --containers ktx2,gltf --verify 0
for p in @babylonjs/core @babylonjs/loaders gltf-validator; do
  [ -f "$NODE_DIR/node_modules/$p/package.json" ] ||
    { echo "FAIL: $NODE_DIR/node_modules/$p missing after npm ci"; FAILURES=$((FAILURES + 1)); }
done
if [ "$FAILURES" -eq "$before" ]; then
  CHROMIUM="$CHROMIUM" run_node babylon babylon_run.mjs "$OUT" "$SETS/white-gltf" "$SETS/patches-gltf" \
    "$SETS/courtyard-gltf"
fi
echo "(Babylon.js and gltf-validator checks done: $(($(date +%s) - START)) s)"

# --- 4. Filament in Chromium (KTX1 as cmgen writes it) ---------------------------------------------
# The white furnace, the skybox and the spheres' orientation (a negative control mirrored in x),
# and spheres per roughness against a CPU render of Filament's shading from the set's KTX2 files.
before=$FAILURES
make_set filament-white white.exr --size 64 --containers ktx1 --verify 0
make_set filament-patches patches.exr --size 128 --containers ktx2,ktx1 --verify 0
make_set filament-courtyard courtyard.exr --size 128 --containers ktx2,ktx1 --format r11g11b10f --verify 0
if [ "$FAILURES" -eq "$before" ]; then
  run_node break-ktx1 break_ktx1.mjs "$SETS/filament-patches" "$SETS/filament-broken-mirror-x"
  CHROMIUM="$CHROMIUM" run_node filament run_filament.mjs "$OUT" "$SETS/filament-white" \
    "$SETS/filament-patches" "$SETS/filament-courtyard" --broken "$SETS/filament-broken-mirror-x"
fi
echo "(Filament done: $(($(date +%s) - START)) s)"

# --- 5. The shader library (WGSL) in Chromium's WebGPU ---------------------------------------------
# SHRMs of a bundled real map as `shrm prefilter --ktx2` writes them, evaluated by
# shaders/wgsl/shrm.wgsl (the per-frame pass of eq. 5.35, eq. 5.10 per direction) against shrm's own
# CPU evaluation of the same files (`shrm render`). tests/engines/run_shaders.mjs, docs/shaders.md.
before=$FAILURES
SHRMS="$TMP/shrms"
mkdir -p "$SHRMS"
# The "-n" pair: in the normal variable (shrm:view_variable "normal", docs/shaders.md) with GGX
# f0 0.04, whose SHRMs carry the Fresnel table (shrm:fresnel) the shaders multiply by; the "-v"
# pair: the same BRDF in the view variable, which carries the table too (conventions 4).
# The "-l" pair: GGX f0 0.04 in the normal variable with peak lights (shrm:lights and
# shrm:light_model), from city.exr, whose sun splits off as 29 lights (courtyard has none).
for name in global local global-n local-n global-v local-v global-l local-l; do
  kind=${name%-[nvl]}
  variable=view
  brdf=microfacet:sigma=0.3
  map=$COURTYARD
  lights=()
  case "$name" in
  *-n) variable=normal brdf=ggx:alpha=0.3,f0=0.04 ;;
  *-v) brdf=ggx:alpha=0.3,f0=0.04 ;;
  *-l) variable=normal brdf=ggx:alpha=0.3,f0=0.04 map="$ROOT/data/envmaps/city.exr" lights=(--peak-lights) ;;
  esac
  if "$SHRM" prefilter --env "$map" --brdf "$brdf" --orders 8,3 --size 16 "${lights[@]}" \
    --kind "$kind" --view-variable "$variable" -o "$SHRMS/$name.shrm.exr" \
    --ktx2 "$SHRMS/$name.shrm.ktx2" --threads 2 >"$TMP/shrm-$name.log" 2>&1 &&
    "$SHRM" render --shrm "$SHRMS/$name.shrm.ktx2" --view 0.3,0.5,0.8 -o "$SHRMS/$name-ref.ktx2" \
      >>"$TMP/shrm-$name.log" 2>&1; then
    echo "PASS: shrm prefilter --brdf $brdf --kind $kind --view-variable $variable ${lights[*]} --ktx2, shrm render --view 0.3,0.5,0.8 ($(basename "$map"))"
  else
    echo "FAIL: shrm prefilter/render ($name):"
    cat "$TMP/shrm-$name.log"
    FAILURES=$((FAILURES + 1))
  fi
done
if [ "$FAILURES" -eq "$before" ]; then
  CHROMIUM="$CHROMIUM" run_node shaders run_shaders.mjs "$ROOT/shaders/wgsl/shrm.wgsl" \
    "$SHRMS/global.shrm.ktx2" "$SHRMS/global-ref.ktx2" "$SHRMS/local.shrm.ktx2" "$SHRMS/local-ref.ktx2" \
    "$SHRMS/global-n.shrm.ktx2" "$SHRMS/global-n-ref.ktx2" "$SHRMS/local-n.shrm.ktx2" "$SHRMS/local-n-ref.ktx2" \
    "$SHRMS/global-v.shrm.ktx2" "$SHRMS/global-v-ref.ktx2" "$SHRMS/local-v.shrm.ktx2" "$SHRMS/local-v-ref.ktx2" \
    "$SHRMS/global-l.shrm.ktx2" "$SHRMS/global-l-ref.ktx2" "$SHRMS/local-l.shrm.ktx2" "$SHRMS/local-l-ref.ktx2"
fi
echo "(shaders done: $(($(date +%s) - START)) s)"

# --- 6. The visual report (shrm prefilter --report-html) in Chromium ------------------------------
# One self-contained HTML file: no console error, no request beyond the file itself, every plot
# and picture drawn (element screenshots non-blank), with negative controls.
# tests/engines/run_report.mjs, docs/cli.md "Visual report".
if "$SHRM" prefilter --env "$COURTYARD" --brdf ggx:alpha=0.3,f0=1 --tolerance 0.02 --verify 64 --threads 2 \
  -o "$TMP/report.shrm.exr" --report-html "$TMP/report.html" >"$TMP/shrm-report.log" 2>&1; then
  echo "PASS: shrm prefilter --report-html (courtyard, GGX alpha 0.3 f0 1, tolerance 0.02)"
  mkdir -p "$CACHE/engines-out"
  CHROMIUM="$CHROMIUM" run_node report run_report.mjs "$TMP/report.html" "$CACHE/engines-out"
else
  echo "FAIL: shrm prefilter --report-html:"
  cat "$TMP/shrm-report.log"
  FAILURES=$((FAILURES + 1))
fi
echo "(report done: $(($(date +%s) - START)) s)"

PASSED=$(cat "$TMP"/*.out | grep -c '^PASS' || true)
echo "engines_test: $(($(date +%s) - START)) s"
echo "$PASSED passed, $FAILURES failed"
[ "$FAILURES" -eq 0 ]
