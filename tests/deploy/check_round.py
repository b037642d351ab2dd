#!/usr/bin/python3
"""Checks one `shrm batch` round of tests/deploy_test.sh and removes its verified outputs.

  check_round.py ROUND_DIR REF_DIR JOBS

ROUND_DIR holds manifest.json, rc (the batch's exit code), summary.txt (stdout: the --json
summary or the text table) and out/ (the outputs); REF_DIR/out holds the single-daemon
reference outputs. Checks: exit code 0; the summary lists each job index 0..JOBS-1 exactly once,
every one "ok" (none failed, none skipped: each round writes to a fresh folder); out/ holds
exactly the expected files, each byte-identical to the reference. Writes ROUND_DIR/check.json
{"jobs", "ok", "retries", "problems"}; outputs that match are deleted (disk space), the others
are kept for inspection. Exit 0 (the caller aggregates the problems).
"""
import filecmp
import json
import os
import re
import sys

TOTAL_RE = re.compile(
    r"^(\d+) jobs: (\d+) ok, (\d+) skipped, (\d+) missed, (\d+) failed, (\d+) retries$")


def parse_summary(text, problems):
    """-> (list of (index, status, output basename, retries or None), total retries or None)."""
    text = text.strip()
    if text.startswith("{"):
        s = json.loads(text)
        jobs = [(j["index"], j["status"], os.path.basename(j["output"]), j.get("retries"))
                for j in s["jobs"]]
        total = s.get("retries")
        if total is None:
            problems.append('--json summary has no "retries" total')
        for j in s["jobs"]:
            if "retries" not in j:
                problems.append('--json summary: job %s has no "retries"' % j["index"])
                break
        return jobs, total
    # The text table: "#  job  status  orders  [retries]  seconds  message", then the total.
    lines = text.splitlines()
    jobs, total = [], None
    for line in lines[1:]:
        m = TOTAL_RE.match(line)
        if m:
            total = int(m.group(6))
            continue
        cols = line.split()
        if len(cols) >= 3 and cols[0].isdigit():
            jobs.append((int(cols[0]), cols[2], os.path.basename(cols[1]), None))
    if total is None:
        problems.append("no 'N jobs: a ok, b skipped, k missed, c failed, r retries' line in the summary")
    return jobs, total


def main(argv):
    round_dir, ref_dir, njobs = argv[1], argv[2], int(argv[3])
    problems = []
    rc = open(os.path.join(round_dir, "rc")).read().strip()
    if rc != "0":
        problems.append("batch exit code %s" % rc)
    jobs, total = [], None
    try:
        with open(os.path.join(round_dir, "summary.txt")) as f:
            jobs, total = parse_summary(f.read(), problems)
    except (OSError, ValueError, KeyError) as e:
        problems.append("unreadable summary: %s" % e)
    indices = sorted(j[0] for j in jobs)
    if indices != list(range(njobs)):
        problems.append("summary lists job indices %s, expected 0..%d once each"
                        % (indices, njobs - 1))
    bad = [j for j in jobs if j[1] != "ok"]
    if bad:
        problems.append("jobs not ok: %s" % ", ".join("%d %s" % (j[0], j[1]) for j in bad))
    retries = total if total is not None else 0
    per_job = [j[3] for j in jobs if j[3] is not None]
    if per_job and total is not None and sum(per_job) != total:
        problems.append("per-job retries sum to %d, the total says %d" % (sum(per_job), total))

    out_dir = os.path.join(round_dir, "out")
    ref_out = os.path.join(ref_dir, "out")
    expected = sorted(os.listdir(ref_out))
    found = sorted(os.listdir(out_dir)) if os.path.isdir(out_dir) else []
    if found != expected:
        missing = sorted(set(expected) - set(found))
        extra = sorted(set(found) - set(expected))
        problems.append("outputs: missing %s, unexpected %s" % (missing, extra))
    summary_names = sorted(j[2] for j in jobs)
    if jobs and summary_names != expected:
        problems.append("the summary's outputs differ from the reference's file names")
    identical = 0
    for name in found:
        ref = os.path.join(ref_out, name)
        out = os.path.join(out_dir, name)
        if os.path.exists(ref) and filecmp.cmp(out, ref, shallow=False):
            identical += 1
            os.remove(out)
        else:
            problems.append("%s differs from the single-daemon output" % name)
    result = {"jobs": len(jobs), "ok": len(jobs) - len(bad), "identical": identical,
              "retries": retries, "problems": problems}
    with open(os.path.join(round_dir, "check.json"), "w") as f:
        json.dump(result, f)
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv))
