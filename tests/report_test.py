#!/usr/bin/python3
"""The visual report of `shrm prefilter --report-html` (docs/cli.md "Visual report").

Usage: report_test.py SHRM REPO_ROOT   (CTest: report_test)

On two bundled real maps and BRDFs:
  - the numbers the page shows are those of independent commands at the same (N, V): the SHRM
    value is what `shrm eval` gives from the written file, the brute-force value what
    `shrm reference` gives (the full sum over the map's pixels), and the error shown is the
    relative error of those two (pairs of the error map and cells of the spheres, the worst and
    a spread of others);
  - the report's own pair statistics equal the job's check (`--verify 256`: the same seeded pairs);
  - the page is self-contained: a Content-Security-Policy that allows no network, every src and
    href a data: URI or a fragment, no script but the JSON data block; every section and picture
    is there and every inlined PNG is a PNG of the stated size;
  - bad input: an unwritable --report-html path fails before any work (no stage ran) and leaves
    no output behind.
The browser half (no console errors, no requests, non-blank plots) is tests/engines/run_report.mjs.
"""
import base64
import json
import os
import re
import shutil
import struct
import subprocess
import sys
import tempfile

# `shrm eval` prints 9 significant digits of the same double the report holds (17 digits).
EVAL_RELATIVE = 1e-7
# The report's brute-force values come from FastReference (relative 1e-3 per direction and
# channel, against max(|B|, a floor of 1% of the mean radiance): core/shrm/fast_reference.h);
# `shrm reference` is the exact sum. Twice the bound leaves room for the floor's definition.
REFERENCE_RELATIVE = 2e-3
# A shown error e = |g - r| / max(|r|, f) moves by at most (1 + e) x the reference's relative
# error when r does.
ERROR_ABSOLUTE = 2 * REFERENCE_RELATIVE
# Pairs and cells checked per report (each costs one `shrm reference`, ~20-60 ms).
CHECKED_PAIRS = 6
CHECKED_CELLS = 3

FAILURES = []


def check(ok, message):
    print(("ok: " if ok else "FAIL: ") + message)
    if not ok:
        FAILURES.append(message)


def run(args, **kw):
    return subprocess.run(args, capture_output=True, text=True, **kw)


def report_data(html):
    m = re.search(r"<script type='application/json' id='shrm-report-data'>(.*?)</script>", html, re.S)
    if not m:
        return None
    return json.loads(m.group(1))


def rgb_of(out):
    return json.loads(out)["rgb"]


def vec_arg(v):
    return ",".join(repr(float(x)) for x in v)


def png_size(b64):
    raw = base64.b64decode(b64)
    if raw[:8] != b"\x89PNG\r\n\x1a\n" or raw[12:16] != b"IHDR":
        return None
    return struct.unpack(">II", raw[16:24])


def relative_error(got, ref, floor):
    return max(abs(g - r) / max(abs(r), f) for g, r, f in zip(got, ref, floor))


def check_page_is_self_contained(html, name):
    check("Content-Security-Policy" in html and "default-src 'none'" in html and
          "img-src data:" in html, f"{name}: CSP forbids every fetch but data: images")
    bad = [u for u in re.findall(r"\s(?:src|href)='([^']*)'", html)
           if not (u.startswith("data:") or u.startswith("#"))]
    check(not bad, f"{name}: every src/href is data: or a fragment ({len(bad)} others: {bad[:3]})")
    scripts = re.findall(r"<script[^>]*>", html)
    check(scripts == ["<script type='application/json' id='shrm-report-data'>"],
          f"{name}: no script but the JSON data block ({scripts[:3]})")
    urls = set(re.findall(r"(?:https?|ftp|wss?)://[^\s'\"<>)]+", html)) - {"http://www.w3.org/2000/svg"}
    check(not urls, f"{name}: no URL but the SVG namespace ({sorted(urls)[:3]})")
    for section in ["summary", "inputs", "orders", "spheres", "errors", "timings"]:
        check(f"id='{section}'" in html, f"{name}: section {section}")
    for svg in ["lobe-plot", "accuracy-plot", "error-map", "timings-plot"]:
        check(f"<svg id='{svg}'" in html, f"{name}: plot {svg}")


def check_report(shrm, root, map_name, brdf, extra, tmp):
    name = f"{map_name} x {brdf}"
    env = os.path.join(root, "data", "envmaps", map_name)
    out = os.path.join(tmp, "r.shrm.exr")
    page = os.path.join(tmp, "r.html")
    report = os.path.join(tmp, "r.json")
    p = run([shrm, "prefilter", "--env", env, "--brdf", brdf, "--verify", "256", "--threads", "2",
             "-o", out, "--report", report, "--report-html", page] + extra)
    check(p.returncode == 0, f"{name}: prefilter --report-html exits 0 ({p.stderr.strip()[:300]})")
    if p.returncode != 0:
        return
    with open(page, encoding="utf-8") as f:
        html = f.read()
    with open(report) as f:
        rep = json.load(f)
    check_page_is_self_contained(html, name)
    data = report_data(html)
    check(data is not None, f"{name}: the JSON data block parses")
    if data is None:
        return
    vis = data["visuals"]
    check(data["report"]["F_B"] == rep["F_B"] and data["report"]["P_B"] == rep["P_B"] and
          data["report"]["measured"] == rep["measured"],
          f"{name}: the page's report is the --report JSON (orders, measured)")
    # The same seeded pairs as the job's check.
    pairs = vis["pairs"]
    check(pairs["front"] == rep["measured"]["front"] and pairs["grazing"] == rep["measured"]["grazing"],
          f"{name}: the error map's statistics = the job's --verify 256 "
          f"(front RMS {pairs['front']['rms']:.4g}, largest {pairs['front']['max']:.4g})")
    # The pictures: PNGs of the stated sizes.
    m = re.search(r"<img class='map'[^>]*src='data:image/png;base64,([^']*)'", html)
    check(m is not None and png_size(m.group(1)) == (vis["map"]["width"], vis["map"]["height"]),
          f"{name}: the map thumbnail is a {vis['map']['width']} x {vis['map']['height']} PNG")
    spheres = re.findall(r"<img class='sphere'[^>]*src='data:image/png;base64,([^']*)'", html)
    size = vis["spheres"]["size"]
    check(len(spheres) == 3 and all(png_size(s) == (3 * size, size) for s in spheres),
          f"{name}: three sphere pictures (SHRM, brute force, error) of {3 * size} x {size}")

    floor = pairs["floor"]
    points = pairs["points"]
    worst = max(range(len(points)), key=lambda k: points[k]["error"])
    first_grazing = next((k for k in range(len(points)) if points[k]["grazing"]), 1)
    chosen = sorted({worst, first_grazing, 0, len(points) // 3, len(points) // 2, len(points) - 1})
    chosen = chosen[:CHECKED_PAIRS]
    cells = []
    for view in vis["spheres"]["views"]:
        s = view["samples"]
        cells.append(max(s, key=lambda c: c["error"]))
    for label, items in (("pair", [points[k] for k in chosen]), ("cell", cells[:CHECKED_CELLS])):
        for item in items:
            n, v = vec_arg(item["index"]), vec_arg(item["view"])
            e = run([shrm, "eval", "--shrm", out, "--normal", n, "--view", v, "--json"])
            r = run([shrm, "reference", "--env", env, "--brdf", brdf, "--normal", n, "--view", v,
                     "--json"])
            if e.returncode != 0 or r.returncode != 0:
                check(False, f"{name}: eval/reference at N {n} V {v}: {e.stderr}{r.stderr}")
                continue
            got, ref = rgb_of(e.stdout), rgb_of(r.stdout)
            ok_eval = all(abs(a - b) <= EVAL_RELATIVE * max(abs(b), 1e-30)
                          for a, b in zip(item["shrm"], got))
            ok_ref = all(abs(a - b) <= REFERENCE_RELATIVE * max(abs(b), f)
                         for a, b, f in zip(item["reference"], ref, floor))
            shown, actual = item["error"], relative_error(got, ref, floor)
            ok_err = abs(shown - actual) <= ERROR_ABSOLUTE * (1 + actual)
            check(ok_eval and ok_ref and ok_err,
                  f"{name}: {label} N ({n}) V ({v}): SHRM {item['shrm'][0]:.6g} = eval "
                  f"{got[0]:.6g}, brute force {item['reference'][0]:.6g} ~ reference {ref[0]:.6g}, "
                  f"error shown {shown:.4g} ~ eval vs reference {actual:.4g}")


def check_unwritable(shrm, root, tmp):
    env = os.path.join(root, "data", "envmaps", "courtyard.exr")
    out = os.path.join(tmp, "u.shrm.exr")
    p = run([shrm, "prefilter", "--env", env, "--brdf", "phong:s=32", "--verbose", "-o", out,
             "--report-html", "/nonexistent/r.html"])
    check(p.returncode == 1 and "shrm: error:" in p.stderr and "/nonexistent/r.html" in p.stderr,
          f"unwritable --report-html: exit 1 naming the path ({p.returncode}: {p.stderr.strip()[:200]})")
    check("decode" not in p.stderr, "unwritable --report-html: refused before any stage ran")
    check(not os.path.exists(out), "unwritable --report-html: no SHRM file left behind")
    left = [f for f in os.listdir(tmp) if ".tmp-" in f]
    check(not left, f"unwritable --report-html: no temporaries ({left})")


def check_hostile_name(shrm, root, tmp):
    """A map whose name holds markup: escaped in the page, intact in its data."""
    name = "<b>x'&<script><!--.exr"  # no '/': it is a file name
    env = os.path.join(tmp, name)
    shutil.copyfile(os.path.join(root, "data", "envmaps", "forest.exr"), env)
    page = os.path.join(tmp, "h.html")
    p = run([shrm, "prefilter", "--env", env, "--brdf", "phong:s=32", "--epsilon", "0.03",
             "--verify", "0", "--size", "16", "-o",
             os.path.join(tmp, "h.shrm.exr"), "--report-html", page])
    check(p.returncode == 0, f"markup in the map's name: prefilter exits 0 ({p.stderr.strip()[:200]})")
    if p.returncode != 0:
        return
    with open(page, encoding="utf-8") as f:
        html = f.read()
    check("<b>x" not in html and "<!--" not in html,
          "markup in the map's name: escaped everywhere in the page")
    data = report_data(html)
    check(data is not None and data["report"]["source"] == [env],
          "markup in the map's name: the data block parses and keeps the name")


def main():
    if len(sys.argv) != 3:
        print(__doc__)
        return 2
    shrm, root = sys.argv[1], sys.argv[2]
    with tempfile.TemporaryDirectory(prefix="shrm_report_test.") as tmp:
        check_unwritable(shrm, root, tmp)
        check_hostile_name(shrm, root, tmp)
        check_report(shrm, root, "courtyard.exr", "microfacet:sigma=0.2", ["--epsilon", "0.03"],
                     tmp)
        check_report(shrm, root, "city.exr", "phong:s=128", ["--tolerance", "0.01"], tmp)
        # Peak lights (docs/shrm.md): the page, `shrm eval` (which sums the file's lights with
        # its shrm:brdf) and the brute force of the whole map agree.
        check_report(shrm, root, "city.exr", "microfacet:sigma=0.3",
                     ["--epsilon", "0.1", "--peak-lights"], tmp)
    print(f"report_test: {len(FAILURES)} failures")
    return 1 if FAILURES else 0


if __name__ == "__main__":
    sys.exit(main())
