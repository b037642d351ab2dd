#!/usr/bin/env bash
# The main job: installs what is missing, builds, and prefilters a bundled real HDR map with a
# glossy BRDF with the defaults (a per-direction tolerance of 1%, checked at 64 seeded pairs
# against the brute-force sum; half floats keep the file at about 120 MB): writes the SHRM, its JSON report, a PNG preview
# and the visual report (one HTML page: docs/cli.md "Visual report") into out/, then checks the
# SHRM against brute-force integration at one (N, V).
# Extra arguments replace the defaults of `shrm prefilter`, e.g.
#   bash scripts/demo.sh --env data/envmaps/city.exr --brdf ggx:alpha=0.3 --tolerance 0.02 -o out/city.shrm.exr
set -euo pipefail
cd "$(dirname "$0")/.."
bash scripts/install-deps.sh
bash scripts/build.sh >/dev/null
SHRM="${SHRM_BUILD_DIR:-build}/cli/shrm"
mkdir -p out
if [ $# -gt 0 ]; then
  exec "$SHRM" prefilter "$@"
fi
ENV=data/envmaps/courtyard.exr
BRDF=microfacet:sigma=0.2
"$SHRM" prefilter --env "$ENV" --brdf "$BRDF" --half \
  -o out/courtyard.shrm.exr --report out/courtyard.report.json --preview out/courtyard.png \
  --report-html out/courtyard.html
echo
echo "SHRM at N = (0.3, 0.8, 0.52), V = (0.1, 0.2, 0.97) vs brute force over the map's pixels:"
echo "  eval      $("$SHRM" eval --shrm out/courtyard.shrm.exr --normal 0.3,0.8,0.52 --view 0.1,0.2,0.97)"
echo "  reference $("$SHRM" reference --env "$ENV" --brdf "$BRDF" --normal 0.3,0.8,0.52 --view 0.1,0.2,0.97)"
echo
echo "outputs: out/courtyard.shrm.exr (SHRM), out/courtyard.report.json, out/courtyard.png (preview),"
echo "         out/courtyard.html (visual report: open it in a browser)"
