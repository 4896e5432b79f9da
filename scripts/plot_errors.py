#!/usr/bin/env python3
"""Draws the error plots of an `evaluate --csv` file (thesis Fig. 42/44 style).

    scripts/plot_errors.py errors.csv [out.png]

Per end: position error scatter in the world x-y plane and x-z plane [mm], and the axis-angle
error over time [deg]. Uses Debian's matplotlib (python3-matplotlib).
"""
import csv
import sys

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402


def main(path, out):
    rows = list(csv.DictReader(open(path)))
    if not rows:
        sys.exit(f"plot_errors: {path} has no rows")
    ends = sorted({r["end"] for r in rows})
    fig, axes = plt.subplots(len(ends), 3, figsize=(13, 4 * len(ends)), squeeze=False)
    for i, end in enumerate(ends):
        rs = [r for r in rows if r["end"] == end]
        ex = [1e3 * float(r["ex_m"]) for r in rs]
        ey = [1e3 * float(r["ey_m"]) for r in rs]
        ez = [1e3 * float(r["ez_m"]) for r in rs]
        t0 = float(rs[0]["stamp_s"])
        t = [float(r["stamp_s"]) - t0 for r in rs]
        ang = [float(r["axis_angle_deg"]) for r in rs]
        for ax, (a, b, la, lb) in zip(axes[i][:2], [(ex, ey, "x", "y"), (ex, ez, "x", "z")]):
            ax.scatter(a, b, s=6)
            ax.axhline(0, color="k", lw=0.5)
            ax.axvline(0, color="k", lw=0.5)
            ax.set_xlabel(f"{la} error [mm]")
            ax.set_ylabel(f"{lb} error [mm]")
            ax.set_title(f"{end}: position error ({la}-{lb})")
            ax.set_aspect("equal", adjustable="datalim")
        axes[i][2].plot(t, ang, ".", ms=3)
        axes[i][2].set_xlabel("time [s]")
        axes[i][2].set_ylabel("axis angle error [deg]")
        axes[i][2].set_title(f"{end}: axis angle error")
    fig.tight_layout()
    fig.savefig(out, dpi=90)
    print(f"wrote {out}")


if __name__ == "__main__":
    if len(sys.argv) < 2:
        sys.exit(__doc__)
    main(sys.argv[1], sys.argv[2] if len(sys.argv) > 2 else sys.argv[1].rsplit(".", 1)[0] + ".png")
