#!/usr/bin/python3
"""The defaults table of docs/results.md: `shrm prefilter` with the per-direction tolerance rule
(`--tolerance 0.01`, within the default 256 MB size budget) and with the paper's `--epsilon 0.03`
(today's default),
on the four bundled maps x the issue's BRDFs, each measured by the job's own check (`--verify
256`: seeded pairs the order choice did not use, against the brute-force sum within 1e-3), one
thread, wall time of the whole process.

  scripts/defaults_table.py run [--shrm build/cli/shrm] [--json docs/data/defaults.json]

The figure and the markdown table of docs/results.md come from the JSON: `scripts/plots.py
defaults` and `scripts/plots.py table defaults`.

`run` takes about 15 minutes on one core of the reference machine.

  scripts/defaults_table.py normal [--shrm build/cli/shrm] [--json docs/data/defaults_normal.json]
  scripts/defaults_table.py auto [--shrm build/cli/shrm] [--json docs/data/defaults_auto.json]
  scripts/defaults_table.py normal-table [--json docs/data/defaults_normal.json]
  scripts/defaults_table.py default [--shrm build/cli/shrm] [--json docs/data/defaults_s22.json]
  scripts/defaults_table.py default-table [--json docs/data/defaults_s22.json]

The view variable (docs/shrm.md "The view variable"): the view-dependent BRDFs only, with the
default rule as it is since session 21 (`--tolerance 0.01`, the normal variable, the grazing RMS
a target), and the markdown table of docs/results.md beside the rows of the same jobs in the
view variable (docs/data/defaults.json's "tolerance 0.01", session 13). `auto` runs the default
(`--tolerance 0.01`, `--view-variable auto`) on the rows where the normal variable's choice
misses the tolerance in estimated front RMS (there auto also chooses in the view variable and
keeps the smaller estimate; elsewhere it is the normal row itself), and the table takes its
rows from it.

`default` runs the default job on all 28 view-dependent rows (`--verify N`: its check at N pairs
instead of 256; session 25 reran it at 2048 to see how the figures move with the sample) (session 22: the normal variable's
C^1 extension, the batched estimate), and `default-table` prints its table beside session 21's
default of each row (its auto row where auto ran, else the normal row), or with `--before
OLD.json --before-label NAME` beside an earlier `default` run (session 23: `--json
docs/data/defaults_s23.json --before docs/data/defaults_s22.json --before-label "session 22"`).
"""
import argparse
import json
import os
import subprocess
import sys
import tempfile
import time

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
MAPS = ["courtyard", "city", "forest", "interior"]
BRDFS = [
    "phong:s=8", "phong:s=32", "phong:s=128", "phong:s=512",
    "microfacet:sigma=0.1", "microfacet:sigma=0.2", "microfacet:sigma=0.3",
    "ggx:alpha=0.1,f0=0.04", "ggx:alpha=0.1,f0=1", "ggx:alpha=0.3,f0=0.04", "ggx:alpha=0.3,f0=1",
]
RULES = {"tolerance 0.01": ["--tolerance", "0.01"], "epsilon 0.03": ["--epsilon", "0.03"]}
NORMAL_RULE = ("tolerance 0.01, normal", ["--tolerance", "0.01", "--view-variable", "normal"])
AUTO_RULE = ("tolerance 0.01, auto", ["--tolerance", "0.01"])
TOLERANCE = 0.01
VERIFY = 256


def run_one(shrm, env, brdf, rule_args, tmp):
    out = os.path.join(tmp, "x.shrm.exr")
    report = os.path.join(tmp, "x.json")
    for f in (out, report):
        if os.path.exists(f):
            os.remove(f)
    cmd = [shrm, "prefilter", "--env", env, "--brdf", brdf, "--verify", str(VERIFY),
           "--threads", "1", "-o", out, "--report", report] + rule_args
    start = time.monotonic()
    p = subprocess.run(cmd, capture_output=True, text=True)
    wall = time.monotonic() - start
    row = {"exit": p.returncode, "wall_s": round(wall, 3)}
    if not os.path.exists(report):
        row["error"] = p.stderr.strip().splitlines()[-1] if p.stderr.strip() else "no report"
        return row
    with open(report) as f:
        r = json.load(f)
    row.update({
        "F_B": r["F_B"], "P_B": r["P_B"], "face_size": r["face_size"],
        "file_mb": round(os.path.getsize(out) / 1e6, 3),
        "measured": r.get("measured"),
        "timings": r.get("timings"),
        "view_variable": r.get("view_variable", "view"),
    })
    if "tolerance" in r:
        t = r["tolerance"]
        row["estimate_front"] = t["estimate"]["front"]
        row["met"] = t["met"]
        row["budget_limited"] = t.get("budget_limited", False)
    return row


def print_row(row, label):
    """One measured row on stdout as the sweep goes."""
    meas = row.get("measured") or {}
    print(f"{label} exit {row['exit']} {row.get('F_B', '-')},{row.get('P_B', '-')} "
          f"S {row.get('face_size', '-')} {row.get('file_mb', '-')} MB {row['wall_s']} s "
          f"front {meas.get('front', {}).get('rms', '-')} / "
          f"{meas.get('front', {}).get('max', '-')} grazing "
          f"{meas.get('grazing', {}).get('rms', '-')}", flush=True)


def sweep(args, rules, brdfs):
    """run_one for every map x BRDF x rule, printed as it goes, written to args.json."""
    rows = []
    with tempfile.TemporaryDirectory() as tmp:
        for m in MAPS:
            env = os.path.join(ROOT, "data", "envmaps", m + ".exr")
            for b in brdfs:
                for rule, rule_args in rules.items():
                    row = run_one(args.shrm, env, b, rule_args, tmp)
                    row.update({"map": m, "brdf": b, "rule": rule})
                    rows.append(row)
                    print_row(row, f"{m:10s} {b:24s} {rule:13s}")
    with open(args.json, "w") as f:
        json.dump({"verify_pairs": VERIFY, "rows": rows}, f, indent=1)
        f.write("\n")


def cmd_run(args):
    sweep(args, RULES, BRDFS)


def cmd_normal(args):
    # Radially symmetric BRDFs (Phong) are left out: P = 0, the view variable does not enter.
    sweep(args, dict([NORMAL_RULE]), [b for b in BRDFS if not b.startswith("phong")])


def cmd_auto(args):
    """The default job on the rows whose normal-variable choice misses the tolerance in estimated
    front RMS (the rows where auto also tries the view), keeping rows already in args.json."""
    with open(args.normal_json) as f:
        normal = json.load(f)["rows"]
    rows = []
    if os.path.exists(args.json):
        with open(args.json) as f:
            rows = json.load(f)["rows"]
    done = {(r["map"], r["brdf"]) for r in rows}
    rule, rule_args = AUTO_RULE
    with tempfile.TemporaryDirectory() as tmp:
        for n in normal:
            key = (n["map"], n["brdf"])
            if key in done or n.get("estimate_front", {}).get("rms", 0) <= TOLERANCE:
                continue
            env = os.path.join(ROOT, "data", "envmaps", n["map"] + ".exr")
            row = run_one(args.shrm, env, n["brdf"], rule_args, tmp)
            row.update({"map": n["map"], "brdf": n["brdf"], "rule": rule})
            rows.append(row)
            print(f"{n['map']:10s} {n['brdf']:24s} auto: {row.get('view_variable')} "
                  f"{row.get('F_B', '-')},{row.get('P_B', '-')} {row['wall_s']} s", flush=True)
            with open(args.json, "w") as f:
                json.dump({"verify_pairs": VERIFY, "rows": rows}, f, indent=1)
                f.write("\n")


def cmd_default(args):
    """The default job (`--tolerance 0.01`, `--view-variable auto`) on every view-dependent row."""
    sweep(args, dict([AUTO_RULE]), [b for b in BRDFS if not b.startswith("phong")])


# The issue's table-BRDF row: a model sampled by `shrm brdf-table` at its default 128 x 64 x 64
# cells, prefiltered as `table:PATH` by the default job (labelled by the model it samples).
TABLE_MODEL = "ggx:alpha=0.3,f0=1"


def cmd_table(args):
    """The default job with the table BRDF (TABLE_MODEL sampled) on the four maps."""
    with tempfile.TemporaryDirectory() as tmp:
        path = os.path.join(tmp, "model.shrmbrdf")
        subprocess.run([args.shrm, "brdf-table", "--brdf", TABLE_MODEL, "-o", path], check=True,
                       capture_output=True)
        rows = []
        for m in MAPS:
            env = os.path.join(ROOT, "data", "envmaps", m + ".exr")
            row = run_one(args.shrm, env, "table:" + path, AUTO_RULE[1], tmp)
            row.update({"map": m, "brdf": "table (" + TABLE_MODEL + ")", "rule": AUTO_RULE[0]})
            rows.append(row)
            print_row(row, f"{m:10s} table")
    with open(args.json, "w") as f:
        json.dump({"verify_pairs": VERIFY, "rows": rows}, f, indent=1)
        f.write("\n")


def session21_default(key):
    """Session 21's default for a row: its auto row where auto ran, else the normal row."""
    out = {}
    for name in ("defaults_normal.json", "defaults_auto.json"):
        path = os.path.join(ROOT, "docs", "data", name)
        if os.path.exists(path):
            with open(path) as f:
                out.update({(r["map"], r["brdf"]): r for r in json.load(f)["rows"]})
    return out.get(key)


def meets(r):
    m = (r or {}).get("measured") or {}
    front, graze = m.get("front", {}), m.get("grazing", {})
    return (front.get("rms", 1) <= TOLERANCE and front.get("max", 1) <= 5 * TOLERANCE and
            graze.get("rms", 1) <= 5 * TOLERANCE)


def cmd_default_table(args):
    with open(args.json) as f:
        rows = json.load(f)["rows"]
    earlier = session21_default
    label = "session 21"
    if args.before:
        with open(args.before) as f:
            before_rows = {(r["map"], r["brdf"]): r for r in json.load(f)["rows"]}
        earlier = before_rows.get
        label = args.before_label

    def cells(r):
        if r is None or "F_B" not in r:
            return ["-", "-", "-", "-", "-", "-"]
        m = r.get("measured") or {}
        front, graze = m.get("front", {}), m.get("grazing", {})
        budget = " (budget)" if r.get("budget_limited") else ""
        return [f"{r.get('view_variable', 'view')} ({r['F_B']}, {r['P_B']}), {r['face_size']}{budget}",
                f"{r['file_mb']:.3g}", f"{r['wall_s']:.3g}",
                f"{front.get('rms', 0):.3g} / {front.get('max', 0):.3g}",
                f"{graze.get('rms', 0):.3g}", "yes" if meets(r) else "no"]

    print("| map | BRDF | default: variable (F, P), S | MB | s | front RMS / largest | grazing RMS "
          f"| all met | {label}: variable (F, P), S | MB | s | front RMS / largest | grazing RMS "
          "| all met |")
    print("|---|---|---|---|---|---|---|---|---|---|---|---|---|---|")
    now = before = 0
    for r in rows:
        key = (r["map"], r["brdf"])
        old = earlier(key)
        now += meets(r)
        before += meets(old)
        print("| " + " | ".join([r["map"], r["brdf"]] + cells(r) + cells(old)) + " |")
    print(f"\nAll three targets met: {now} of {len(rows)} rows ({label}: {before}).")


def cmd_normal_table(args):
    with open(args.json) as f:
        normal = json.load(f)["rows"]
    with open(os.path.join(ROOT, "docs", "data", "defaults.json")) as f:
        view = {(r["map"], r["brdf"]): r for r in json.load(f)["rows"] if r["rule"] == "tolerance 0.01"}
    auto = {}
    auto_path = os.path.join(ROOT, "docs", "data", "defaults_auto.json")
    if os.path.exists(auto_path):
        with open(auto_path) as f:
            auto = {(r["map"], r["brdf"]): r for r in json.load(f)["rows"]}

    def cells(r):
        if r is None or "F_B" not in r:
            return ["-", "-", "-", "-", "-"]
        m = r.get("measured") or {}
        front, graze = m.get("front", {}), m.get("grazing", {})
        budget = " (budget)" if r.get("budget_limited") else ""
        return [f"({r['F_B']}, {r['P_B']}), {r['face_size']}{budget}", f"{r['file_mb']:.3g}",
                f"{r['wall_s']:.3g}", f"{front.get('rms', 0):.3g} / {front.get('max', 0):.3g}",
                f"{graze.get('rms', 0):.3g}"]

    print("| map | BRDF | normal: (F, P), S | MB | s | front RMS / largest | grazing RMS "
          "| view (session 13): (F, P), S | MB | s | front RMS / largest | grazing RMS "
          "| default (auto) takes |")
    print("|---|---|---|---|---|---|---|---|---|---|---|---|---|")
    for r in normal:
        key = (r["map"], r["brdf"])
        a = auto.get(key)
        takes = ("normal (its estimate within 1%)" if a is None else
                 f"{a.get('view_variable', '?')} ({a['wall_s']:.3g} s)")
        print("| " + " | ".join([r["map"], r["brdf"]] + cells(r) + cells(view.get(key)) +
                                [takes]) + " |")


def main(argv):
    global VERIFY
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawTextHelpFormatter)
    sub = ap.add_subparsers(dest="cmd", required=True)
    r = sub.add_parser("run")
    r.add_argument("--shrm", default=os.path.join(ROOT, "build", "cli", "shrm"))
    r.add_argument("--json", default=os.path.join(ROOT, "docs", "data", "defaults.json"))
    n = sub.add_parser("normal")
    n.add_argument("--shrm", default=os.path.join(ROOT, "build", "cli", "shrm"))
    n.add_argument("--json", default=os.path.join(ROOT, "docs", "data", "defaults_normal.json"))
    a = sub.add_parser("auto")
    a.add_argument("--shrm", default=os.path.join(ROOT, "build", "cli", "shrm"))
    a.add_argument("--json", default=os.path.join(ROOT, "docs", "data", "defaults_auto.json"))
    a.add_argument("--normal-json",
                   default=os.path.join(ROOT, "docs", "data", "defaults_normal.json"))
    d = sub.add_parser("default")
    d.add_argument("--shrm", default=os.path.join(ROOT, "build", "cli", "shrm"))
    d.add_argument("--json", default=os.path.join(ROOT, "docs", "data", "defaults_s22.json"))
    d.add_argument("--verify", type=int, default=256,
                   help="the job's check pairs (default %(default)s; session 25's recheck: 2048)")
    dt = sub.add_parser("default-table")
    dt.add_argument("--json", default=os.path.join(ROOT, "docs", "data", "defaults_s22.json"))
    dt.add_argument("--before", help="an earlier `default` JSON to compare with (default: "
                    "session 21's rows)")
    dt.add_argument("--before-label", default="before")
    tb = sub.add_parser("table")
    tb.add_argument("--shrm", default=os.path.join(ROOT, "build", "cli", "shrm"))
    tb.add_argument("--json", default=os.path.join(ROOT, "docs", "data", "defaults_table_brdf.json"))
    t = sub.add_parser("normal-table")
    t.add_argument("--json", default=os.path.join(ROOT, "docs", "data", "defaults_normal.json"))
    args = ap.parse_args(argv)
    VERIFY = getattr(args, "verify", 256)
    {"run": cmd_run, "normal": cmd_normal, "auto": cmd_auto, "default": cmd_default,
     "default-table": cmd_default_table, "normal-table": cmd_normal_table,
     "table": cmd_table}[args.cmd](args)


if __name__ == "__main__":
    main(sys.argv[1:])
