#!/usr/bin/env bash
# Writes the outputs of the CLI, batch and service for the bundled maps into OUT_DIR, so that two
# builds (for example the last commit before a refactoring and the one after) can be compared
# byte for byte:
#   bash scripts/compare-outputs.sh OLD_BUILD_DIR /tmp/old
#   bash scripts/compare-outputs.sh build /tmp/new
#   diff -r /tmp/old /tmp/new && echo identical
# SHRM files, previews, irradiance crosses and printed values are written as they are; JSON
# reports and summaries lose their wall-clock fields (timings, seconds) and the server's address.
set -euo pipefail
trap 'echo "compare-outputs: failed at line $LINENO (see $OUT)" >&2' ERR
BUILD=$(cd "$1" && pwd)
OUT=$2
ROOT=$(cd "$(dirname "$0")/.." && pwd)
SHRM=$BUILD/cli/shrm
[ -x "$SHRM" ] || SHRM=$BUILD/client/shrm  # before the cli/ folder existed
SHRMD=$BUILD/server/shrmd
MAPS=$ROOT/data/envmaps
rm -rf "$OUT"
mkdir -p "$OUT"/cli "$OUT"/remote "$OUT"/batch "$OUT"/spool
cd "$OUT"

strip_json() {  # FILE: drops timings, seconds and the server address, sorted keys
  python3 - "$1" <<'PY'
import json, sys
def clean(x):
    if isinstance(x, dict):
        return {k: clean(v) for k, v in x.items() if k not in ("timings", "seconds", "server")}
    if isinstance(x, list):
        return [clean(v) for v in x]
    return x
p = sys.argv[1]
d = json.load(open(p))
open(p, "w").write(json.dumps(clean(d), indent=1, sort_keys=True) + "\n")
PY
}

# A GGX table BRDF file (a file-based BRDF travels as a blob).
JOBS=(
  "courtyard microfacet:sigma=0.2 --epsilon 0.03"
  "city ggx:alpha=0.3,f0=0.04 --epsilon 0.05 --kind local --size 32"
  "interior phong:s=32 --orders 12,0 --size 40 --half"
  "forest ward:alpha=0.2 --orders 10,2 --size 24 --rotate 30,10,5"
  "courtyard lafortune:cx=-1,cy=-1,cz=1,n=20 --epsilon 0.1 --kind local --size 32"
  "city lambert --orders 4,0 --size 16"
)
i=0
for j in "${JOBS[@]}"; do
  read -r map brdf rest <<<"$j"
  # shellcheck disable=SC2086
  "$SHRM" prefilter --env "$MAPS/$map.exr" --brdf "$brdf" $rest --threads 2 -o "cli/$i.shrm.exr" \
    --report "cli/$i.json" --preview "cli/$i.png" >/dev/null 2>>errors.log
  strip_json "cli/$i.json"
  i=$((i + 1))
done
"$SHRM" analyze --env "$MAPS/city.exr" --brdf phong:s=16 --json >cli/analyze.json 2>/dev/null
strip_json cli/analyze.json
"$SHRM" analyze --brdf microfacet:sigma=0.3 --json >cli/analyze_brdf.json 2>/dev/null
"$SHRM" reference --env "$MAPS/forest.exr" --brdf phong:s=8 --normal 0.3,0.8,0.52 \
  --view 0.1,0.2,0.97 >cli/reference.txt 2>/dev/null
"$SHRM" eval --shrm cli/0.shrm.exr --normal 0.3,0.8,0.52 --view 0.1,0.2,0.97 >cli/eval.txt
"$SHRM" irradiance --env "$MAPS/interior.exr" --rotate 10,0,0 -o cli/irradiance.exr --json \
  >cli/irradiance.json 2>/dev/null
"$SHRM" info --json cli/2.shrm.exr >cli/info.json

# The same jobs on a daemon.
PORT=$((40000 + $$ % 20000))
"$SHRMD" --listen "127.0.0.1:$PORT" --spool-dir spool --max-jobs 2 >shrmd.log 2>&1 &
DAEMON=$!
trap 'kill $DAEMON 2>/dev/null || true' EXIT
for _ in $(seq 100); do
  "$SHRM" analyze --brdf phong:s=8 --server "127.0.0.1:$PORT" >/dev/null 2>&1 && break
  sleep 0.1
done
i=0
for j in "${JOBS[@]}"; do
  read -r map brdf rest <<<"$j"
  # shellcheck disable=SC2086
  "$SHRM" prefilter --env "$MAPS/$map.exr" --brdf "$brdf" $rest -o "remote/$i.shrm.exr" \
    --report "remote/$i.json" --server "127.0.0.1:$PORT" >/dev/null 2>>errors.log
  strip_json "remote/$i.json"
  i=$((i + 1))
done
"$SHRM" reference --env "$MAPS/forest.exr" --brdf phong:s=8 --normal 0.3,0.8,0.52 \
  --view 0.1,0.2,0.97 --server "127.0.0.1:$PORT" >remote/reference.txt 2>/dev/null
"$SHRM" irradiance --env "$MAPS/interior.exr" --rotate 10,0,0 -o remote/irradiance.exr \
  --server "127.0.0.1:$PORT" >/dev/null 2>&1
"$SHRM" analyze --env "$MAPS/city.exr" --brdf phong:s=16 --json --server "127.0.0.1:$PORT" \
  >remote/analyze.json 2>/dev/null
strip_json remote/analyze.json

# A batch (resumable: a second run skips every job).
cat >batch/manifest.json <<JSON
{"maps": ["$MAPS/courtyard.exr", "$MAPS/interior.exr"],
 "brdfs": ["phong:s=16", "microfacet:sigma=0.3"],
 "options": {"orders": "10,2", "size": 24, "report": true, "rotate": [20, 0, 0]},
 "output": "out/{map}_{brdf}.shrm.exr"}
JSON
"$SHRM" batch batch/manifest.json --json >batch/summary.json 2>/dev/null
"$SHRM" batch batch/manifest.json --json >batch/summary2.json 2>/dev/null
for f in batch/summary.json batch/summary2.json batch/out/*.json; do strip_json "$f"; done
kill $DAEMON 2>/dev/null || true
wait $DAEMON 2>/dev/null || true
rm -rf spool shrmd.log errors.log
echo "compare-outputs: wrote $(find . -type f | wc -l) files to $OUT"
