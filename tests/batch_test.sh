#!/usr/bin/env bash
# Acceptance test of `shrm batch` (docs/cli.md): a 2 maps x 2 BRDFs manifest run with --jobs 2
# must write four outputs byte-identical to single `shrm prefilter` runs; a rerun skips all four
# (resume); a changed or corrupt output, or a changed manifest option, is recomputed (and only
# that); a manifest with bad content is rejected up front with JSON paths and nothing runs; a job
# failing at run time (truncated EXR) makes the exit code 1 while the other jobs complete; an ibl
# manifest writes the single `shrm ibl` sets, resumes, and has its options checked up front.
#
# Usage: batch_test.sh SHRM_BINARY REPO_ROOT   (registered with CTest as batch_test)
set -u

if [ $# -ne 2 ]; then
  echo "usage: $0 SHRM_BINARY REPO_ROOT" >&2
  exit 2
fi
SHRM=$1
ROOT=$2
[ -x "$SHRM" ] || { echo "not executable: $SHRM" >&2; exit 2; }
for m in courtyard city; do
  [ -f "$ROOT/data/envmaps/$m.exr" ] || { echo "missing bundled map: $m.exr" >&2; exit 2; }
done

TMP=$(mktemp -d "${TMPDIR:-/tmp}/shrm_batch_test.XXXXXX")
trap 'rm -rf "$TMP"' EXIT
cd "$TMP" || exit 2

FAILURES=0
fail() {
  echo "FAIL: $*"
  FAILURES=$((FAILURES + 1))
}
# count STATUS FILE: how many jobs of a --json summary have that status.
count() { grep -c "\"status\": \"$1\"" "$2"; }

mkdir maps other
cp "$ROOT/data/envmaps/courtyard.exr" "$ROOT/data/envmaps/city.exr" maps/
cp "$ROOT/data/envmaps/city.exr" other/
BYTES=$(stat -c %s maps/city.exr)
head -c $((BYTES / 3)) maps/city.exr >maps/truncated.exr

BRDFS=("phong:s=32" "microfacet:sigma=0.2")
NAMES=("phong_s_32" "microfacet_sigma_0.2")
manifest() {  # manifest FILE EPSILON
  cat >"$1" <<JSON
{"maps": ["maps/courtyard.exr", "maps/city.exr"],
 "brdfs": ["phong:s=32", "microfacet:sigma=0.2"],
 "options": {"epsilon": $2, "size": 16, "kind": "global", "ktx2": true, "verify": 0},
 "output": "out/{map}_{brdf}.shrm.exr"}
JSON
}

# --- 1. the 2 x 2 batch equals single prefilter runs ---------------------------------------
echo "== 2 x 2 batch, --jobs 2"
manifest batch.json 0.1
"$SHRM" batch batch.json --jobs 2 --json >run1.json 2>run1.err
rc=$?
[ $rc -eq 0 ] || fail "batch exit $rc: $(cat run1.err)"
[ "$(count ok run1.json)" -eq 4 ] || fail "first run: expected 4 ok: $(cat run1.json)"
# "verify": 0 in this manifest: nothing measured, and the summary says so.
[ "$(grep -c '"measured": null' run1.json)" -eq 4 ] || fail "unmeasured jobs: $(cat run1.json)"
mkdir single
for m in courtyard city; do
  for i in 0 1; do
    out="out/${m}_${NAMES[$i]}.shrm.exr"
    ref="single/${m}_${NAMES[$i]}.shrm.exr"
    [ -f "$out" ] || { fail "missing $out"; continue; }
    "$SHRM" prefilter --env "maps/$m.exr" --brdf "${BRDFS[$i]}" --epsilon 0.1 --size 16 --verify 0 \
      -o "$ref" --ktx2 "${ref%.exr}.ktx2" >/dev/null 2>&1 || fail "prefilter $m ${BRDFS[$i]} failed"
    cmp -s "$out" "$ref" || fail "$out differs from the single prefilter output"
    # "ktx2": true in the manifest: <stem>.shrm.ktx2 next to each output (docs/formats.md).
    cmp -s "${out%.exr}.ktx2" "${ref%.exr}.ktx2" || fail "${out%.exr}.ktx2 differs from --ktx2's"
  done
done
ls out/*.tmp-* >/dev/null 2>&1 && fail "temporaries left in out/"

# --- 2. resume: everything skipped ----------------------------------------------------------
echo "== rerun: all skipped"
"$SHRM" batch batch.json --jobs 2 --json >run2.json 2>run2.err || fail "rerun exit $?"
[ "$(count skipped run2.json)" -eq 4 ] || fail "rerun: expected 4 skipped: $(cat run2.json)"

# --- 3. a changed and a corrupt output are recomputed, only them ----------------------------
echo "== changed / corrupt outputs recomputed"
"$SHRM" prefilter --env maps/city.exr --brdf phong:s=32 --epsilon 0.2 --size 16 --verify 0 \
  -o out/city_phong_s_32.shrm.exr >/dev/null 2>&1 || fail "prefilter at epsilon 0.2 failed"
head -c 100 single/courtyard_microfacet_sigma_0.2.shrm.exr >out/courtyard_microfacet_sigma_0.2.shrm.exr
"$SHRM" batch batch.json --jobs 2 --json >run3.json 2>run3.err || fail "run 3 exit $?"
[ "$(count ok run3.json)" -eq 2 ] || fail "run 3: expected 2 recomputed: $(cat run3.json)"
[ "$(count skipped run3.json)" -eq 2 ] || fail "run 3: expected 2 skipped: $(cat run3.json)"
for f in city_phong_s_32 courtyard_microfacet_sigma_0.2; do
  cmp -s "out/$f.shrm.exr" "single/$f.shrm.exr" || fail "out/$f.shrm.exr not restored"
done
# A different manifest epsilon: every job recomputed; --force: everything recomputed.
manifest batch2.json 0.2
"$SHRM" batch batch2.json --json >run4.json 2>run4.err || fail "run 4 exit $?"
[ "$(count ok run4.json)" -eq 4 ] || fail "epsilon change: expected 4 recomputed: $(cat run4.json)"
"$SHRM" batch batch2.json --force --json >run5.json 2>run5.err || fail "run 5 exit $?"
[ "$(count ok run5.json)" -eq 4 ] || fail "--force: expected 4 recomputed: $(cat run5.json)"
# The text summary.
"$SHRM" batch batch2.json >run6.txt 2>&1 || fail "run 6 exit $?"
grep -q "4 jobs: 0 ok, 4 skipped, 0 missed, 0 failed, 0 retries" run6.txt || fail "summary line: $(cat run6.txt)"
grep -q "measured rms/max" run6.txt || fail "summary header: $(cat run6.txt)"

# A job that checks itself (--verify): the summary's measured error is its report's front figures.
cat >verify.json <<'JSON'
{"maps": ["maps/courtyard.exr"], "brdfs": ["phong:s=32"],
 "options": {"epsilon": 0.1, "size": 16, "verify": 32, "report": true},
 "output": "verified/{map}_{brdf}.shrm.exr"}
JSON
"$SHRM" batch verify.json --json >verify.out 2>verify.err || fail "verify batch exit $?: $(cat verify.err)"
python3 - verify.out <<'PY' || fail "measured error in the summary: $(cat verify.out)"
import json, sys
job = json.load(open(sys.argv[1]))["jobs"][0]
front = json.load(open(job["output"][: -len(".shrm.exr")] + ".json"))["measured"]["front"]
assert job["measured"] == {"rms": front["rms"], "max": front["max"]}, (job["measured"], front)
PY

# Visual reports ("report_html": true): one page per job and the index next to the manifest,
# linking each page (relative links that resolve) with a thumbnail each; a resumed batch keeps
# them (thumbnails from the pages it skipped); an index that cannot be written fails up front.
echo "== visual reports and their index"
# Small constant maps (PFM of ones): the pages' numbers are report_test's; this is the index,
# and the pages' brute-force sums stay cheap under the sanitizers.
mkdir -p small
for m in white grey; do
  { printf 'PF\n64 32\n-1.0\n'; head -c $((64 * 32 * 3 * 4)) /dev/zero | tr '\0' '\1'; } >small/$m.pfm
done
cat >visual.json <<'JSON'
{"maps": ["small/white.pfm", "small/grey.pfm"], "brdfs": ["phong:s=32"],
 "options": {"epsilon": 0.1, "size": 16, "verify": 32, "report_html": true},
 "output": "visual/{map}_{brdf}.shrm.exr"}
JSON
check_index() {  # check_index LABEL
  python3 - visual.html <<'PY' || fail "$1 index: $(head -c 300 visual.html)"
import os, re, sys
html = open(sys.argv[1], encoding="utf-8").read()
links = re.findall(r"<a href='([^']*)'>", html)
assert links == ["visual/white_phong_s_32.report.html", "visual/grey_phong_s_32.report.html"], links
for link in links:
    page = open(os.path.join(os.path.dirname(sys.argv[1]), link), encoding="utf-8").read()
    assert "id='shrm-report-data'" in page and "<svg id='accuracy-plot'" in page, link
thumbs = re.findall(r"<img class='sphere'[^>]*src='data:image/png;base64,", html)
assert len(thumbs) == 2, len(thumbs)
assert "Content-Security-Policy" in html
PY
}
"$SHRM" batch visual.json --json >visual.out 2>visual.err || fail "visual batch exit $?: $(cat visual.err)"
check_index first
"$SHRM" batch visual.json --json >visual2.out 2>visual2.err || fail "visual rerun exit $?"
[ "$(count skipped visual2.out)" -eq 2 ] || fail "visual rerun: expected 2 skipped: $(cat visual2.out)"
check_index resumed
rm visual/grey_phong_s_32.report.html
"$SHRM" batch visual.json --json >visual3.out 2>visual3.err || fail "visual rerun 3 exit $?"
grep -q '"message": "recomputed: visual report missing"' visual3.out ||
  fail "a missing report page is not recomputed: $(cat visual3.out)"
mkdir ro_manifest && sed 's|"small/|"../small/|g' visual.json >ro_manifest/visual.json
mkdir ro_manifest/visual.html  # a folder where the index page would go
"$SHRM" batch ro_manifest/visual.json >ro.out 2>ro.err && fail "an unwritable index was accepted"
grep -q 'visual.html' ro.err || fail "unwritable index: no path in: $(cat ro.err)"
[ -e ro_manifest/visual ] && fail "unwritable index: jobs ran before the check"

# --- 4. bad manifests are rejected up front -------------------------------------------------
echo "== bad manifests rejected before any job"
cat >bad.json <<'JSON'
{"maps": ["maps/courtyard.exr", "maps/nosuch.exr"], "brdfs": ["phong:s=32", "nosuch:x=1"],
 "options": {"epsilon": 0.1, "size": 16, "colour": 1}, "output": "bad/{map}_{brdf}.shrm.exr",
 "extra": true}
JSON
"$SHRM" batch bad.json >bad.out 2>bad.err
rc=$?
[ $rc -eq 1 ] || fail "bad manifest: exit $rc, expected 1"
for p in '$.brdfs[1]' '$.maps[1]' '$.options.colour' '$.extra'; do
  grep -qF "$p" bad.err || fail "bad manifest: $p not reported: $(cat bad.err)"
done
[ -e bad ] && fail "bad manifest: something ran (bad/ exists)"
cat >dup.json <<'JSON'
{"maps": ["maps/city.exr", "other/city.exr"], "brdfs": ["phong:s=32"],
 "options": {"size": 16}, "output": "dup/{map}_{brdf}.shrm.exr"}
JSON
"$SHRM" batch dup.json >dup.out 2>dup.err
[ $? -eq 1 ] || fail "duplicate outputs: expected exit 1"
grep -q "both write" dup.err || fail "duplicate outputs not reported: $(cat dup.err)"
[ -e dup ] && fail "duplicate outputs: something ran"
cat >nopat.json <<'JSON'
{"maps": ["maps/city.exr"], "brdfs": ["phong:s=32", "phong:s=8"], "output": "x/{map}.shrm.exr"}
JSON
"$SHRM" batch nopat.json >/dev/null 2>nopat.err
[ $? -eq 1 ] || fail "pattern without {brdf}: expected exit 1"
grep -qF '$.output' nopat.err || fail "pattern without {brdf} not reported: $(cat nopat.err)"
# A pattern that does not name an OpenEXR file (the SHRMs were written as EXR named out/*.png).
cat >png.json <<'JSON'
{"maps": ["maps/city.exr"], "brdfs": ["phong:s=32"], "output": "x/{map}.png"}
JSON
"$SHRM" batch png.json >/dev/null 2>png.err
[ $? -eq 1 ] || fail "pattern of a .png: expected exit 1"
grep -qF '$.output: the SHRMs are written as OpenEXR: the pattern must end in .exr' png.err ||
  fail "pattern of a .png not reported: $(cat png.err)"
[ -e x ] && fail "pattern of a .png: something ran"
echo '{"maps": [' >notjson.json
"$SHRM" batch notjson.json >/dev/null 2>notjson.err
[ $? -eq 1 ] || fail "malformed JSON: expected exit 1"
"$SHRM" batch batch.json --jobs 0 >/dev/null 2>&1
[ $? -eq 2 ] || fail "--jobs 0: expected usage error 2"

# --- 5. a job failing at run time -----------------------------------------------------------
echo "== a failing job, the others complete"
cat >fails.json <<'JSON'
{"maps": ["maps/truncated.exr", "maps/courtyard.exr"], "brdfs": ["phong:s=32"],
 "options": {"epsilon": 0.1, "size": 16, "verify": 0}, "output": "fails/{map}_{brdf}.shrm.exr"}
JSON
"$SHRM" batch fails.json --jobs 2 --json >fails.out 2>fails.err
rc=$?
[ $rc -eq 1 ] || fail "failing job: exit $rc, expected 1"
[ "$(count failed fails.out)" -eq 1 ] || fail "failing job: expected 1 failed: $(cat fails.out)"
[ "$(count ok fails.out)" -eq 1 ] || fail "failing job: expected 1 ok: $(cat fails.out)"
cmp -s fails/courtyard_phong_s_32.shrm.exr single/courtyard_phong_s_32.shrm.exr ||
  fail "failing batch: the good output is missing or differs"
[ -e fails/truncated_phong_s_32.shrm.exr ] && fail "failing job left an output"
grep -q "1 of 2 jobs failed" fails.err || fail "failing job: no error line: $(cat fails.err)"

# A job that misses its tolerance (the default rule, 1%, on a 16-texel cube, which cannot hold
# Phong s = 32's F_B = 20): "missed", its file written and complete, its figures in the message,
# the batch's exit 1; a rerun does not recompute it (it is the job's output, only not within its
# tolerance) but reports it missed again, from the verdict its header records, and exits 1.
echo "== a job that misses its tolerance"
cat >missed.json <<'JSON'
{"maps": ["maps/courtyard.exr"], "brdfs": ["phong:s=32"],
 "options": {"size": 16}, "output": "missed/{map}_{brdf}.shrm.exr"}
JSON
"$SHRM" batch missed.json --json >missed.out 2>missed.err
rc=$?
[ $rc -eq 1 ] || fail "missed tolerance: exit $rc, expected 1"
[ "$(count missed missed.out)" -eq 1 ] || fail "missed tolerance: expected 1 missed: $(cat missed.out)"
grep -q '"message": "tolerance 0.01 not met' missed.out || fail "missed tolerance: no figures: $(cat missed.out)"
grep -q '"orders": "20,0"' missed.out || fail "missed tolerance: no orders: $(cat missed.out)"
grep -q "0 of 1 jobs failed, 1 missed their tolerance" missed.err ||
  fail "missed tolerance: no error line: $(cat missed.err)"
"$SHRM" info missed/courtyard_phong_s_32.shrm.exr >missed.info 2>&1 &&
  grep -q 'shrm:measured_error' missed.info || fail "missed tolerance: the file is not complete: $(cat missed.info)"
grep -q 'shrm:tolerance_met *false' missed.info || fail "missed tolerance: no verdict in the header: $(cat missed.info)"
cp missed/courtyard_phong_s_32.shrm.exr missed_first.exr
"$SHRM" batch missed.json --json >missed2.out 2>missed2.err
rc=$?
[ $rc -eq 1 ] || fail "missed tolerance: the rerun exits $rc, expected 1 (a miss is not forgotten)"
[ "$(count missed missed2.out)" -eq 1 ] || fail "missed tolerance: the rerun does not report the miss: $(cat missed2.out)"
grep -q '"message": "up to date, not recomputed: tolerance 0.01 not met when written: measured front RMS' missed2.out ||
  fail "missed tolerance: the rerun's message: $(cat missed2.out)"
grep -q '"rms": ' missed2.out || fail "missed tolerance: the rerun shows no measured error: $(cat missed2.out)"
cmp -s missed/courtyard_phong_s_32.shrm.exr missed_first.exr || fail "missed tolerance: the rerun rewrote the file"
# A job that met its tolerance is skipped on a rerun, with the measured error its header records.
"$SHRM" batch verify.json --json >met2.out 2>&1 || fail "rerun of a met batch: $(cat met2.out)"
[ "$(count skipped met2.out)" -eq 1 ] || fail "rerun of a met batch: expected 1 skipped: $(cat met2.out)"
grep -q '"measured": null' met2.out && fail "a skipped job shows no measured error: $(cat met2.out)"

# --- 6. --server (when shrmd is built next to shrm): same files, each map uploaded once ---------
SHRMD="$(dirname "$SHRM")/../server/shrmd"
if [ -x "$SHRMD" ]; then
  echo "== --server"
  "$SHRMD" --listen 127.0.0.1:0 --spool-dir "$TMP/spool" >shrmd.log 2>&1 &
  SHRMD_PID=$!
  trap 'kill $SHRMD_PID 2>/dev/null; wait $SHRMD_PID 2>/dev/null; rm -rf "$TMP"' EXIT
  PORT=""
  for _ in $(seq 50); do
    PORT=$(grep -o '"port":"[0-9]*"' shrmd.log | grep -o '[0-9][0-9]*')
    [ -n "$PORT" ] && break
    sleep 0.1
  done
  if [ -z "$PORT" ]; then
    fail "shrmd did not start: $(cat shrmd.log)"
  else
    sed 's#"out/#"remote/#' batch.json >remote.json
    "$SHRM" batch remote.json --jobs 2 --server "127.0.0.1:$PORT" --json >remote.out 2>remote.err ||
      fail "--server batch exit $?: $(cat remote.err)"
    [ "$(count ok remote.out)" -eq 4 ] || fail "--server: expected 4 ok: $(cat remote.out)"
    for f in single/*.shrm.exr single/*.shrm.ktx2; do
      cmp -s "$f" "remote/$(basename "$f")" || fail "--server: remote/$(basename "$f") differs"
    done
    [ "$(grep -c '"call":"UploadBlob"' shrmd.log)" -le 2 ] || fail "--server: a map uploaded twice"
    # An input the server cannot decode is named by the user's file, not by its blob's hash
    # (the server never says a path of its own).
    printf 'no image format begins like this\n' >notamap.exr
    for cmd in "prefilter --brdf phong:s=32 --env notamap.exr -o bad.shrm.exr" \
      "live --brdf phong:s=32 --sequence notamap.exr -o badlive"; do
      # shellcheck disable=SC2086
      if "$SHRM" $cmd --server "127.0.0.1:$PORT" >bad.out 2>bad.err; then
        fail "--server ${cmd%% *}: a file that is no image was accepted"
      elif ! grep -q 'notamap\.exr: unrecognized file signature' bad.err ||
        grep -Eq 'blob [0-9a-f]{64}' bad.err; then
        fail "--server ${cmd%% *}: the error does not name notamap.exr: $(cat bad.err)"
      fi
    done
  fi
  kill $SHRMD_PID 2>/dev/null
  wait $SHRMD_PID 2>/dev/null
fi

# --- IBL manifests: one set per map, the single run's bytes, resume, options checked up front ---
echo "== ibl manifest"
cat >ibl.json <<'JSON'
{"kind": "ibl", "maps": ["maps/courtyard.exr", "maps/city.exr"],
 "options": {"size": 16, "verify": 2, "irradiance_size": 8, "dfg_size": 16, "sheen": true},
 "output": "ibl/{map}"}
JSON
"$SHRM" batch ibl.json --jobs 2 --json >ibl1.json 2>ibl1.err || fail "ibl batch exit $?: $(cat ibl1.err)"
[ "$(count ok ibl1.json)" -eq 2 ] || fail "ibl batch: expected 2 ok: $(cat ibl1.json)"
# The summary's measured error is the worst level's of each set's own check (ibl.json).
python3 - ibl1.json <<'PY' || fail "ibl batch: measured error in the summary: $(cat ibl1.json)"
import json, sys
summary = json.load(open(sys.argv[1]))
for job in summary["jobs"]:
    report = json.load(open(job["output"] + "/ibl.json"))
    levels = [l["measured"] for c in ("specular", "sheen", "irradiance") if c in report
              for l in report[c]["levels"] if "measured" in l]
    want = {"rms": max(l["rms"] for l in levels), "max": max(l["max"] for l in levels)}
    assert job["measured"] == want, (job["measured"], want)
PY
"$SHRM" ibl --env maps/city.exr --size 16 --verify 2 --irradiance-size 8 --dfg-size 16 --sheen \
  -o ibl_single >/dev/null 2>&1 || fail "single shrm ibl failed"
for f in specular.ktx2 sheen.ktx2 irradiance.ktx2 sh9.json ibl.json; do
  cmp -s "ibl_single/$f" "ibl/city/$f" || fail "ibl batch: ibl/city/$f differs from shrm ibl's"
done
"$SHRM" batch ibl.json --json >ibl2.json 2>/dev/null || fail "ibl rerun exit $?"
[ "$(count skipped ibl2.json)" -eq 2 ] || fail "ibl rerun: expected 2 skipped: $(cat ibl2.json)"
rm ibl/courtyard/sh9.json
"$SHRM" batch ibl.json --json >ibl3.json 2>/dev/null || fail "ibl resume exit $?"
[ "$(count ok ibl3.json)" -eq 1 ] && [ "$(count skipped ibl3.json)" -eq 1 ] ||
  fail "ibl: only the set missing a file must be recomputed: $(cat ibl3.json)"
grep -q '"message": "recomputed: a file is missing"' ibl3.json || fail "ibl: reason missing: $(cat ibl3.json)"
# A set whose ibl.json says it missed its tolerance (the bundled maps meet every tolerance the
# formats allow, so the verdict is edited here): a rerun does not recompute it, reports it
# missed again and exits 1.
python3 - ibl/city/ibl.json <<'PY'
import json, sys
j = json.load(open(sys.argv[1]))
j["met"] = False
json.dump(j, open(sys.argv[1], "w"))
PY
"$SHRM" batch ibl.json --json >ibl4.json 2>/dev/null
rc=$?
[ $rc -eq 1 ] || fail "ibl: a set that missed, rerun: exit $rc, expected 1"
[ "$(count missed ibl4.json)" -eq 1 ] && [ "$(count skipped ibl4.json)" -eq 1 ] ||
  fail "ibl: a set that missed is not reported again: $(cat ibl4.json)"
grep -q '"message": "up to date, not recomputed: a level missed the tolerance' ibl4.json ||
  fail "ibl: the rerun's message: $(cat ibl4.json)"
sed 's/"size": 16/"size": 24/; s/"sheen": true/"sheen": 1, "brdf": "x"/' ibl.json >ibl_bad.json
"$SHRM" batch ibl_bad.json >ibl_bad.out 2>ibl_bad.err
rc=$?
[ $rc -eq 1 ] || fail "bad ibl manifest: exit $rc"
for p in '\$.options.sheen: must be true or false' '\$.options.brdf: unknown option'; do
  grep -q "$p" ibl_bad.err || fail "bad ibl manifest: no '$p' in: $(cat ibl_bad.err)"
done
sed 's/"size": 16/"size": 24/' ibl.json >ibl_bad2.json
"$SHRM" batch ibl_bad2.json >/dev/null 2>ibl_bad2.err && fail "ibl size 24 accepted"
grep -q '\$.options.size: face size 24' ibl_bad2.err || fail "ibl size 24: $(cat ibl_bad2.err)"

if [ $FAILURES -ne 0 ]; then
  echo "$FAILURES failure(s)"
  exit 1
fi
echo "batch_test: all checks passed"
