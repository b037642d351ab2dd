#!/usr/bin/env python3
"""The plots in docs/results.md show the numbers of the tables under them (issue 14).

For each figure of scripts/plots.py: the markdown table under its image in docs/results.md is
parsed, its rows are compared with the values the plot draws (the script's own extraction
functions, the ones the plotting calls, on docs/data/*.json) to the printed precision, and the
whole table must equal what `scripts/plots.py table NAME` prints. Then `scripts/plots.py all`
into a temporary folder must reproduce the committed PNGs byte for byte (needs Debian's
python3-matplotlib, installed by scripts/install-deps.sh; skipped with a message without it).

Run: python3 tests/plots_test.py
"""
import importlib.util
import os
import re
import subprocess
import sys
import tempfile
import unittest

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
RESULTS_MD = os.environ.get("SHRM_RESULTS_MD", os.path.join(ROOT, "docs", "results.md"))
PLOTS_PY = os.path.join(ROOT, "scripts", "plots.py")
SYSTEM_PYTHON = "/usr/bin/python3"  # Debian's, where python3-matplotlib is installed

_spec = importlib.util.spec_from_file_location("plots", PLOTS_PY)
plots = importlib.util.module_from_spec(_spec)
_spec.loader.exec_module(plots)


def table_under_image(md, image):
    """The first markdown table after the line that shows images/<image>.png: the header cells
    and the rows (lists of stripped cell strings)."""
    lines = md.splitlines()
    marker = f"](images/{image}.png)"
    starts = [i for i, line in enumerate(lines) if marker in line]
    if not starts:
        raise AssertionError(f"{RESULTS_MD} does not show images/{image}.png")
    i = starts[0]
    while i < len(lines) and not lines[i].startswith("|"):
        i += 1
    table = []
    while i < len(lines) and lines[i].startswith("|"):
        table.append(lines[i])
        i += 1
    cells = [[c.strip() for c in line.strip().strip("|").split("|")] for line in table]
    return table, cells[0], cells[2:]


def printed_tolerance(text):
    """Half a unit in the last printed digit of a number as formatted in the tables."""
    m = re.fullmatch(r"-?\d+(?:\.(\d+))?(?:e([-+]\d+))?", text)
    if not m:
        raise AssertionError(f"not a number: {text!r}")
    decimals = len(m.group(1) or "")
    exponent = int(m.group(2) or 0)
    return 0.5 * 10.0 ** (exponent - decimals) * (1 + 1e-9)


class PlotValuesMatchTables(unittest.TestCase):
    @classmethod
    def setUpClass(cls):
        with open(RESULTS_MD) as f:
            cls.md = f.read()

    def table(self, name):
        image = plots.FIGURES[name][3]
        return table_under_image(self.md, image)

    def assert_cell(self, cell, value, what):
        tol = printed_tolerance(cell)
        self.assertLessEqual(abs(float(cell) - value), tol,
                             f"{what}: table {cell}, plotted {value!r}")

    def assert_whole_table(self, name):
        lines, _, _ = self.table(name)
        self.assertEqual(lines, plots.table_lines(name),
                         f"docs/results.md's table under the {name} plot differs from "
                         f"`scripts/plots.py table {name}`")

    def test_table_5_4(self):
        _, head, rows = self.table("table-5-4")
        data = plots.table_5_4_rows(*[plots.load(p) for p in plots.data_paths("table-5-4")])
        self.assertEqual(len(rows), len(data))
        col = {h: i for i, h in enumerate(head)}
        for row, d in zip(rows, data):
            self.assertEqual(int(row[col["s"]]), d["s"])
            self.assert_cell(row[col["angular (s)"]], d["angular_s"], f"s={d['s']} angular")
            self.assert_cell(row[col["frequency (ms)"]], d["frequency_ms"], f"s={d['s']} freq")
            self.assert_cell(row[col["ratio"]], d["ratio"], f"s={d['s']} ratio")
            self.assert_cell(row[col["paper angular (s)"]], d["paper_angular_s"], "paper")
            self.assert_cell(row[col["paper ratio"]], d["paper_ratio"], "paper ratio")
        # The paper's values are the thesis's Table 5.4, e.g. s = 8: 67.28 s, 0.081 s, 830.6.
        self.assertEqual(plots.PAPER_TABLE_5_4[8], (67.28, 0.081, 830.6))
        self.assert_whole_table("table-5-4")

    def test_table_5_5(self):
        _, head, rows = self.table("table-5-5")
        data = plots.table_5_5_rows(*[plots.load(p) for p in plots.data_paths("table-5-5")])
        self.assertEqual(len(rows), len(data))
        col = {h: i for i, h in enumerate(head)}
        for row, d in zip(rows, data):
            what = f"sigma={d['sigma']} ({d['f_b']},{d['p_b']})"
            self.assertEqual(row[col["F_B, P_B timed"]].split(" ")[0], f"{d['f_b']},{d['p_b']}")
            self.assert_cell(row[col["SHRM (ms)"]], d["shrm_ms"], what + " SHRM")
            reused, fresh = row[col["100 maps, reused / fresh (ms)"]].split(" / ")
            self.assert_cell(reused, d["maps_ms"], what + " maps")
            self.assert_cell(fresh, d["maps_fresh_ms"], what + " fresh maps")
            self.assert_cell(row[col["angular / image (s)"]], d["angular_per_image_s"], what)
            ours = row[col["`shrm analyze` F_B, P_B at eps .03"]]
            self.assertEqual(ours, f"{d['ours_f']},{d['ours_p']}", what)
            if d["paper"]:
                shrm_s, total_s = row[col["paper SHRM / total (s)"]].split(" / ")
                self.assert_cell(shrm_s, d["paper_shrm_s"], what + " paper SHRM")
                self.assert_cell(total_s, d["paper_total_s"], what + " paper total")
        self.assert_whole_table("table-5-5")

    def test_fig_5_5(self):
        _, head, rows = self.table("fig-5-5")
        cases = plots.fig_5_5_cases(*[plots.load(p) for p in plots.data_paths("fig-5-5")])
        self.assertEqual(len(rows), len(plots.FIG_5_5_MAPS) * len(plots.FIG_5_5_BRDFS))
        self.assertEqual(len(rows), len(cases))
        for row, c in zip(rows, cases):
            self.assertEqual((row[0], row[1]), (c["map"], f"`{c['brdf']}`"))
            self.assertEqual(row[2], f"{c['f_b']},{c['p_b']}")
            self.assertEqual(row[3], f"{c['f_ref']},{c['p_ref']}")
            for k, f in enumerate(plots.FIG_5_5_TABLE_F):
                i = c["F"].index(f)
                cells = row[4 + k].split(" / ")
                for cell, key in zip(cells, ("measured", "estimate", "bound")):
                    self.assert_cell(cell, c[key][i], f"{c['map']} {c['brdf']} F={f} {key}")
        self.assert_whole_table("fig-5-5")

    def test_rotation_fig3(self):
        _, _, rows = self.table("rotation-fig3")
        data = plots.rotation_rows(*[plots.load(p) for p in plots.data_paths("rotation-fig3")])
        self.assertEqual(len(rows), len(data))
        for row, d in zip(rows, data):
            self.assertEqual(int(row[0]), d["n"])
            self.assert_cell(row[1], d["beta_deg"], "beta")
            for k, (key, _) in enumerate(plots.ROTATION_MEASURES):
                for cell, v in zip(row[2 + k].split(" / "), d[key]):
                    self.assert_cell(cell, v, f"n={d['n']} beta={d['beta_deg']} {key}")
        self.assert_whole_table("rotation-fig3")

    def test_hsh_fig4(self):
        _, _, rows = self.table("hsh-fig4")
        data = plots.hsh_rows(*[plots.load(p) for p in plots.data_paths("hsh-fig4")])
        self.assertEqual(len(rows), len(data))
        for row, d in zip(rows, data):
            self.assertEqual(int(row[1]), d["coefficients"])
            for k, (key, *_) in enumerate(plots.HSH_SERIES):
                self.assert_cell(row[2 + k], d[key], f"{d['coefficients']} coefficients {key}")
        self.assert_whole_table("hsh-fig4")

    def test_hbasis_fig3(self):
        _, _, rows = self.table("hbasis-fig3")
        data = plots.hbasis_rows(*[plots.load(p) for p in plots.data_paths("hbasis-fig3")])
        self.assertEqual(len(rows), len(data))
        for row, d in zip(rows, data):
            self.assertEqual(row[0], d["basis"])
            self.assert_cell(row[1], d["a_mean_imse"], d["basis"] + " A")  # the plotted bars
            self.assert_cell(row[4], d["b_mean_imse"], d["basis"] + " B")
        self.assert_whole_table("hbasis-fig3")

    def test_sht(self):
        _, _, rows = self.table("sht")
        data = plots.sht_rows(*[plots.load(p) for p in plots.data_paths("sht")])
        self.assertEqual(len(rows), len(data))
        for row, d in zip(rows, data):
            self.assertEqual((row[0], row[1], int(row[2]), int(row[3])),
                             (d["direction"], d["size"], d["F"], d["threads"]))
            what = f"{d['direction']} {d['size']} F={d['F']}"
            self.assert_cell(row[4], d["shrm_ms"], what + " shrm")
            self.assert_cell(row[5], d["libsharp_ms"], what + " libsharp")
            self.assert_cell(row[6], d["ratio"], what + " ratio")
        self.assert_whole_table("sht")


    def test_defaults(self):
        _, head, rows = self.table("defaults")
        data = plots.defaults_rows(plots.load(plots.data_paths("defaults")[0]))
        self.assertEqual(len(rows), len(data))
        for row, d in zip(rows, data):
            self.assertEqual((row[0], row[1]), (d["map"], d["brdf"]))
            for col, rule in ((5, "tolerance 0.01"), (10, "epsilon 0.03")):
                if row[col] == "":  # refused: nothing plotted
                    self.assertIsNone(plots._front(d.get(rule), "rms"))
                    continue
                rms, largest = row[col].split(" / ")
                self.assert_cell(rms, plots._front(d[rule], "rms"), f"{d['map']} {d['brdf']} rms")
                self.assert_cell(largest, plots._front(d[rule], "max"), f"{d['brdf']} max")
        self.assert_whole_table("defaults")


def matplotlib_python():
    """An interpreter that has matplotlib: this one, else Debian's, else None."""
    for exe in (sys.executable, SYSTEM_PYTHON):
        if exe and os.path.exists(exe) and subprocess.run(
                [exe, "-c", "import matplotlib"], capture_output=True).returncode == 0:
            return exe
    return None


class PngsAreReproducible(unittest.TestCase):
    def test_all_regenerates_committed_pngs(self):
        exe = matplotlib_python()
        if exe is None:
            self.skipTest("matplotlib missing (neither this python3 nor /usr/bin/python3 has "
                          "it; scripts/install-deps.sh installs python3-matplotlib): the PNGs "
                          "were not compared")
        with tempfile.TemporaryDirectory() as tmp:
            subprocess.run([exe, PLOTS_PY, "all", tmp], check=True, capture_output=True)
            for name, (_, _, _, image) in plots.FIGURES.items():
                with open(os.path.join(tmp, f"{image}.png"), "rb") as f:
                    made = f.read()
                with open(os.path.join(ROOT, "docs", "images", f"{image}.png"), "rb") as f:
                    committed = f.read()
                self.assertTrue(made == committed,
                                f"docs/images/{image}.png is not what `scripts/plots.py {name}` "
                                "makes from docs/data (regenerate it: scripts/plots.py all)")


if __name__ == "__main__":
    unittest.main()
