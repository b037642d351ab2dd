#!/usr/bin/env bash
# Makes the seed corpora of the fuzz harnesses (fuzz/corpus/<harness>/, docs/fuzzing.md) from the
# bundled maps and the project's own writers. Run once; scripts/fuzz.sh grows the corpora from
# these. Needs oiiotool (openimageio-tools), protoc and the fuzz build's fuzz_seed_writer
# (scripts/fuzz.sh --build-only builds it). Seeds stay tiny: maps are downsampled to a few texels.
# Image seeds start with the harness's option byte (fuzz/image_fuzzer.cc): bits 0-2 the layout
# (0 auto, 1 latlong, 2 cube faces, 3 hcross, 4 vcross, 5 hstrip, 6 vstrip, 7 angular), bit 3
# replace NaN/Inf, bit 4 six cube-face files.
set -euo pipefail
cd "$(dirname "$0")/.."
BUILD_DIR=${SHRM_FUZZ_BUILD_DIR:-build-fuzz}
C=fuzz/corpus
TMP=$(mktemp -d "${TMPDIR:-/tmp}/shrm-seeds.XXXXXX")
trap 'rm -rf "$TMP"' EXIT
mkdir -p $C/{image,brdf_spec,brdf_table,merl,shrm_file,batch_manifest,config_file,auth,request,ktx_roundtrip,gltf_roundtrip}

# seed HARNESS NAME OPTION_BYTE FILE: the option byte (octal escape) then the file.
seed() { { printf "$3"; cat "$4"; } >"$C/$1/$2"; }

# --- image: every format, EXR compressions, layouts ---------------------------------------------
MAP=data/envmaps/city.exr
oiiotool "$MAP" --resize 16x8 -d float -o "$TMP/ll.exr"
for comp in none rle zips zip piz pxr24 b44 b44a dwaa dwab; do
  oiiotool "$TMP/ll.exr" -d half --compression "$comp" -o "$TMP/ll_$comp.exr"
  seed image "latlong_$comp.exr" '\001' "$TMP/ll_$comp.exr"
done
oiiotool "$TMP/ll.exr" -d float --compression zip -o "$TMP/ll_float.exr"
seed image latlong_float_auto.exr '\000' "$TMP/ll_float.exr"
oiiotool "$TMP/ll.exr" -d half --tile 8 8 -o "$TMP/ll_tiled.exr"
seed image latlong_tiled.exr '\001' "$TMP/ll_tiled.exr"
oiiotool "$TMP/ll.exr" --ch R,G,B,A=1.0 -d half -o "$TMP/ll_rgba.exr"
seed image latlong_rgba.exr '\000' "$TMP/ll_rgba.exr"
oiiotool "$TMP/ll.exr" --ch R -d half -o "$TMP/ll_y.exr"
seed image latlong_grey.exr '\000' "$TMP/ll_y.exr"
oiiotool "$TMP/ll.exr" -o "$TMP/ll.hdr"
seed image latlong.hdr '\000' "$TMP/ll.hdr"
oiiotool "$TMP/ll.exr" -d uint8 -o "$TMP/ll.png"
seed image latlong8.png '\000' "$TMP/ll.png"
oiiotool "$TMP/ll.exr" -d uint16 -o "$TMP/ll16.png"
seed image latlong16.png '\001' "$TMP/ll16.png"
oiiotool "$TMP/ll.exr" -d float -o "$TMP/ll.tif"
seed image latlong_float.tif '\000' "$TMP/ll.tif"
oiiotool "$TMP/ll.exr" -d uint16 --compression lzw -o "$TMP/ll16.tif"
seed image latlong16_lzw.tif '\001' "$TMP/ll16.tif"
oiiotool "$TMP/ll.exr" -d uint8 -o "$TMP/ll8.tif"
seed image latlong8.tif '\000' "$TMP/ll8.tif"
# PFM (Debian's OIIO reads but cannot write it): 4 x 2 RGB little-endian floats, one NaN.
python3 - "$TMP/ll.pfm" <<'PY'
import struct, sys
vals = [0.5, 1.0, 2.0] * 7 + [float('nan'), 0.25, 0.125]
open(sys.argv[1], 'wb').write(b'PF\n4 2\n-1.0\n' + struct.pack('<24f', *vals))
PY
seed image latlong_nan.pfm '\011' "$TMP/ll.pfm"
seed image latlong_nan_reject.pfm '\001' "$TMP/ll.pfm"
# Cube layouts: the sizes decide (S = 4).
oiiotool "$MAP" --resize 16x12 -d half -o "$TMP/hcross.exr"; seed image hcross.exr '\003' "$TMP/hcross.exr"
oiiotool "$MAP" --resize 12x16 -d half -o "$TMP/vcross.exr"; seed image vcross.exr '\004' "$TMP/vcross.exr"
oiiotool "$MAP" --resize 12x16 -o "$TMP/vcross.hdr"; seed image vcross_auto.hdr '\000' "$TMP/vcross.hdr"
oiiotool "$MAP" --resize 24x4 -d half -o "$TMP/hstrip.exr"; seed image hstrip.exr '\005' "$TMP/hstrip.exr"
oiiotool "$MAP" --resize 4x24 -d uint8 -o "$TMP/vstrip.png"; seed image vstrip.png '\006' "$TMP/vstrip.png"
oiiotool "$MAP" --resize 8x8 -d half -o "$TMP/probe.exr"; seed image angular.exr '\007' "$TMP/probe.exr"
oiiotool "$MAP" --resize 4x4 -d half -o "$TMP/face.exr"; seed image cube_faces.exr '\022' "$TMP/face.exr"

# --- BRDF tables and SHRM files: the project's writers -----------------------------------------
"$BUILD_DIR/fuzz/fuzz_seed_writer" "$C"
# MERL: the 12-byte header of a real file alone (its size is checked), a truncated body, and
# two seeds of the lookup mode (byte 0 = 1: the rest are angles).
python3 - "$C/merl" <<'PY'
import os, random, struct, sys
d = sys.argv[1]
hdr = struct.pack('<3i', 90, 90, 180)
open(os.path.join(d, 'header_only.binary'), 'wb').write(b'\0' + hdr)
open(os.path.join(d, 'truncated.binary'), 'wb').write(b'\0' + hdr + struct.pack('<8d', *[0.01] * 8))
random.seed(1)
open(os.path.join(d, 'angles_1.binary'), 'wb').write(b'\1' + bytes(random.getrandbits(8) for _ in range(96)))
open(os.path.join(d, 'angles_2.binary'), 'wb').write(b'\1' + bytes([0] * 48 + [255] * 48))
PY

# --- text inputs ---------------------------------------------------------------------------------
i=0
for s in "phong:s=32" "microfacet:sigma=0.2" "lambert" "lambert:albedo=0.5" "ggx:alpha=0.3,f0=0.04" \
  "ward:alpha_x=0.1,alpha_y=0.3,rho_s=0.5,rho_d=0.2" "kajiya-kay:s=16" \
  "lafortune:cx=-1,cy=-1,cz=1,n=20" "table:@" "latlong" "hcross" "0,1,0" "8,2" "0.001" \
  "rgba16f" "cmgen" "ktx2,ktx1,gltf" "gltf-lut-ggx" "global"; do
  printf '%s' "$s" >"$C/brdf_spec/$(printf %02d $i)"; i=$((i + 1))
done
cat >"$C/batch_manifest/prefilter.json" <<'J'
{"maps": ["map.exr", "sky.hdr"], "brdfs": ["phong:s=32", "microfacet:sigma=0.2"],
 "options": {"epsilon": 0.03, "kind": "global", "size": 0, "half": false,
             "rotate": [0, 0, 0], "report": true, "preview": false},
 "output": "out/{map}_{brdf}.shrm.exr"}
J
cat >"$C/batch_manifest/orders.json" <<'J'
{"maps": ["faces/px.exr"], "brdfs": ["ggx:alpha=0.3"],
 "options": {"orders": "8,2", "window": "lanczos", "verify": 100, "kind": "local", "size": 32},
 "output": "{index}.exr"}
J
cat >"$C/batch_manifest/tolerance.json" <<'J'
{"kind": "prefilter", "maps": ["map.exr"], "brdfs": ["lambert"],
 "options": {"tolerance": 0.01}, "output": "o/{map}.shrm.exr"}
J
cat >"$C/batch_manifest/ibl.json" <<'J'
{"kind": "ibl", "maps": ["map.exr", "sky.hdr"],
 "options": {"size": 128, "sheen": true, "format": "r11g11b10f", "preset": "gltf", "levels": 5,
             "irradiance_size": 16, "dfg_size": 64, "tolerance": 0.001, "verify": 16,
             "sh_window": "cmgen", "dfg": "filament", "containers": "ktx2,ktx1", "preview": true,
             "rotate": [90, 0, 0]},
 "output": "out/{map}_ibl"}
J
cat >"$C/batch_manifest/ibl_explicit.json" <<'J'
{"kind": "ibl", "maps": ["map.exr"], "options": {"roughness": [0, 0.25, 0.5, 1]}, "output": "x"}
J
cat >"$C/config_file/shrmd.conf" <<'J'
# /etc/shrmd.conf
listen = 127.0.0.1:50051
spool-dir = "/var/spool/shrmd"
max-jobs = 2
cache-mib = 512
reflection = true
metrics-port = -1
J
cat >"$C/config_file/tls.conf" <<'J'
tls-cert = "/etc/shrmd/cert.pem"
tls-key = /etc/shrmd/key.pem
tls-client-ca = "/etc/shrmd/ca.pem"
token-file = /etc/shrmd/tokens
reflection = false
grace-period = 30
J
printf 'token-one\n# comment\n\n  token-two  \n\x00\x01127.0.0.1:50051\x00/shrm.v1.Shrm/Prefilter\x00Bearer token-one\x00\x01\x01\x01' \
  >"$C/auth/tokens_loopback"
printf 'abc\n\x00\x01[::]:50051\x00/grpc.health.v1.Health/Check\x00\x00\x00\x01\x01-----BEGIN CERTIFICATE-----\nMIIB\n-----END CERTIFICATE-----\n\x00\x01-----BEGIN PRIVATE KEY-----\n\x00' \
  >"$C/auth/tls"

# --- requests: protobuf wire bytes (byte 0: RPC | 8) from text format, and structured seeds -----
PROTO=proto/shrm/v1/shrm.proto
HASH=$(printf 'x' | sha256sum | cut -c1-64)
wire() {  # wire NAME BYTE MESSAGE TEXT
  { printf "$2"; printf '%s' "$4" | protoc --proto_path=proto --encode="shrm.v1.$3" "$PROTO"; } \
    >"$C/request/$1"
}
wire prefilter '\010' PrefilterRequest "environment { sha256: \"$HASH\" layout: LAYOUT_LATLONG
  rotation { yaw_deg: 90 } source_names: \"map.exr\" } brdf: \"phong:s=32\" epsilon: 0.03
  kind: SHRM_KIND_LOCAL face_size: 32 half: true outputs: OUTPUT_SHRM_FILE verify: 10"
wire prefilter_table '\010' PrefilterRequest "environment { sha256: \"$HASH\" }
  brdf: \"table:@\" brdf_blob_sha256: \"$HASH\" brdf_display_spec: \"table:x.brdf\"
  orders { f: 8 p: 2 } window: RINGING_WINDOW_LANCZOS"
wire prefilter_cube '\010' PrefilterRequest "environment { sha256: \"$HASH\" sha256: \"$HASH\"
  sha256: \"$HASH\" sha256: \"$HASH\" sha256: \"$HASH\" sha256: \"$HASH\" layout: LAYOUT_CUBE_FACES
  non_finite: NON_FINITE_POLICY_REPLACE_ZERO } brdf: \"ggx:alpha=0.2\" tolerance: 0.01"
wire ibl '\011' IblRequest "environment { sha256: \"$HASH\" } preset: IBL_PRESET_EXPLICIT
  roughness: 0 roughness: 0.5 roughness: 1 face_size: 64 levels: 3 sheen: true
  format: IBL_FORMAT_RGB9E5 irradiance_size: 16 dfg_size: 32 tolerance: 0.01 verify: 4
  sh_window: IBL_SH_WINDOW_CMGEN dfg: \"filament\" containers: \"ktx2,ktx1,gltf\" preview: true"
wire analyze '\012' AnalyzeRequest "environment { sha256: \"$HASH\" } brdf: \"phong:s=8\"
  epsilon: 0.1 epsilon: 0.01"
wire reference '\013' ReferenceRequest "environment { sha256: \"$HASH\" } brdf: \"lambert\"
  index { y: 1 } view { z: 1 }"
wire irradiance '\014' IrradianceRequest "environment { sha256: \"$HASH\" layout: LAYOUT_HCROSS }"
for rpc in 0 1 2 3 4; do
  python3 -c "import sys,random; random.seed($rpc); sys.stdout.buffer.write(bytes([$rpc]) + bytes(random.getrandbits(8) for _ in range(160)))" \
    >"$C/request/structured_$rpc"
done
for k in 0 1; do
  for n in 1 2 3; do
    python3 -c "import sys,random; random.seed($n); sys.stdout.buffer.write(bytes([$k]) + bytes(random.getrandbits(8) for _ in range(300 * $n)))" \
      >"$C/ktx_roundtrip/ktx${k}_$n"
  done
done
for n in 1 2 3 4; do
  python3 -c "import sys,random; random.seed(100 + $n); sys.stdout.buffer.write(bytes(random.getrandbits(8) for _ in range(1000 * $n)))" \
    >"$C/gltf_roundtrip/glb_$n"
done
echo "make-fuzz-seeds: $(find $C -type f | wc -l) seeds, $(du -sh $C | cut -f1)"
