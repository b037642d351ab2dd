#!/usr/bin/python3
"""Plots of the project's own measurements for docs/results.md (Debian's python3-matplotlib).

  scripts/plots.py split-sum [JSON] [PNG]
      the split-sum vs SHRM study (bench/split_sum_vs_shrm --json JSON): relative RMS error over
      the view angle for each GGX alpha, per map (thin) and the mean over the maps (bold).
      Defaults: docs/data/split_sum_vs_shrm.json -> docs/images/split_sum_vs_shrm.png.

  scripts/plots.py soak [JSON] [PNG]
      the soak of shrmd (bench/soak_bench SHRMD SECONDS JSON): per minute the p50 and p99
      latency of each call kind (left) and the daemon's RSS, descriptors and threads (right).
      Defaults: docs/data/soak.json -> docs/images/soak.png.

The PNGs carry no time stamp or version, so a regeneration from the same data leaves them
byte-identical.
"""
import json
import os
import sys

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))

# (key in the JSON rows, label, line style, marker): distinguishable in grey scale.
SERIES = [
    ("split_sum_rms", "split-sum (256 chain)", "--", "s"),
    ("shrm_equal_memory_rms", "SHRM, equal memory", "-", "o"),
    ("shrm_rms", "SHRM, tolerance rule", ":", "^"),
]


def split_sum(json_path, png_path):
    with open(json_path) as f:
        data = json.load(f)
    rows = data["rows"]
    alphas = sorted({r["alpha"] for r in rows})
    fig, axes = plt.subplots(1, len(alphas), figsize=(4.2 * len(alphas), 3.8), sharey=True)
    if len(alphas) == 1:
        axes = [axes]
    for ax, alpha in zip(axes, alphas):
        group = [r for r in rows if r["alpha"] == alpha]
        angles = group[0]["angle_deg"]
        for key, label, style, marker in SERIES:
            for r in group:
                ax.plot(angles, r[key], style, color="0.7", linewidth=0.8)
            mean = [sum(r[key][i] for r in group) / len(group) for i in range(len(angles))]
            ax.plot(angles, mean, style, color="black", marker=marker, markersize=4, linewidth=1.6,
                    label=label)
        eq = group[0]["shrm_equal_memory"]
        ax.set_title(f"GGX alpha {alpha:g} (roughness {alpha ** 0.5:.2f})\n"
                     f"equal-memory SHRM: P_B {eq['p_b']}, S_B {eq['s_b']}", fontsize=9)
        ax.set_yscale("log")
        ax.set_xlabel("view angle from the normal (degrees)")
        ax.set_xlim(0, 90)
        ax.grid(True, which="both", color="0.9")
    axes[0].set_ylabel("relative RMS error vs brute force (luminance)")
    axes[0].legend(fontsize=8, loc="upper left")
    maps = ", ".join(sorted({r["map"].replace(".exr", "") for r in rows}))
    fig.suptitle(f"Split-sum vs SHRM on {maps} ({data['width']} x {data['width'] // 2}, "
                 f"{data['samples_per_bin']} (N, V) per bin; grey: each map, black: mean)",
                 fontsize=10)
    fig.tight_layout()
    fig.savefig(png_path, dpi=90, metadata={"Software": None})
    print(f"wrote {png_path}")


def soak(json_path, png_path):
    with open(json_path) as f:
        data = json.load(f)
    rows = data["per_minute"]
    minutes = [r["minute"] for r in rows]
    fig, (lat, res) = plt.subplots(1, 2, figsize=(11, 4.2))
    styles = ["-", "--", ":", "-.", (0, (1, 3))]
    markers = ["o", "s", "^", "v", "D"]
    for i, kind in enumerate(["prefilter", "analyze", "irradiance", "upload", "cancelled"]):
        lat.plot(minutes, [r[kind]["p50_ms"] for r in rows], linestyle=styles[i],
                 marker=markers[i], color="black", label=f"{kind} p50")
        lat.plot(minutes, [r[kind]["p99_ms"] for r in rows], linestyle=styles[i],
                 marker=markers[i], color="grey", markerfacecolor="none", label=f"{kind} p99")
    lat.set_yscale("log")
    lat.set_xlabel("minute")
    lat.set_ylabel("latency (ms)")
    lat.set_title(f"{data['clients']} clients, fixed mix: latency per minute", fontsize=10)
    lat.legend(fontsize=7, ncol=2)
    res.plot(minutes, [r["rss_mib"] for r in rows], "-o", color="black", label="RSS (MiB)")
    res.plot(minutes, [r["fds"] for r in rows], "--s", color="grey", label="open descriptors")
    res.plot(minutes, [r["threads"] for r in rows], ":^", color="black", label="threads")
    res.set_ylim(bottom=0)
    res.set_xlabel("minute")
    res.set_title("shrmd's resources at the end of each minute", fontsize=10)
    res.legend(fontsize=8)
    fig.tight_layout()
    fig.savefig(png_path, dpi=90, metadata={"Software": None})
    print(f"wrote {png_path}")


PLOTS = {
    "split-sum": (split_sum, "split_sum_vs_shrm"),
    "soak": (soak, "soak"),
}


def main(argv):
    if len(argv) < 2 or argv[1] not in PLOTS:
        print(__doc__)
        return 2
    plot, name = PLOTS[argv[1]]
    json_path = argv[2] if len(argv) > 2 else os.path.join(ROOT, f"docs/data/{name}.json")
    png_path = argv[3] if len(argv) > 3 else os.path.join(ROOT, f"docs/images/{name}.png")
    plot(json_path, png_path)
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv))
