#!/usr/bin/env python3
"""Summarises the RESULT lines of bench_estimator into the bench table (scripts/bench).

    bench_summary.py RESULTS                      # the text table (console, .ws/bench/bench.txt)
    bench_summary.py RESULTS --markdown FILE ...  # also writes the markdown results page

With --markdown, only the part of FILE between the BEGIN / END marker lines below is replaced;
a FILE without them starts from --template's text (docs/results.md), or holds the part alone.
"""
import argparse
import os
import sys

BEGIN = "<!-- bench:begin -->"
END = "<!-- bench:end -->"

COLUMNS = ["scenario", "method", "end", "valid", "mean mm", "sd x/y/z mm", "axis deg",
           "<=1cm1deg", "<=2cm2deg", "in 3sig", "ax 3sig", "med ms", "p95 ms", "p99 ms", "RSS MB"]


def parse(path):
    rows = []
    for line in open(path):
        if not line.startswith("RESULT "):
            continue
        kv = dict(f.split("=", 1) for f in line.split()[1:])
        rows.append(kv)
    return rows


def pct(r, key):
    return f"{100 * float(r.get(key, 'nan')):.1f}%"


def cells(r):
    """One table row's cells, formatted alike for text and markdown."""
    sd = f"{float(r['std_x_mm']):.1f}/{float(r['std_y_mm']):.1f}/{float(r['std_z_mm']):.1f}"
    return [r["label"], r["method"], r["end"], f"{r['estimates']}/{r['expected']}",
            f"{float(r['mean_err_mm']):.1f}", sd, f"{float(r['mean_axis_deg']):.2f}",
            pct(r, "within_1cm_1deg"), pct(r, "within_2cm_2deg"), pct(r, "in_3sigma"),
            pct(r, "axis_in_3sigma"), f"{float(r['median_ms']):.2f}", f"{float(r['p95_ms']):.1f}",
            f"{float(r['p99_ms']):.1f}", f"{float(r['rss_mb']):.1f}"]


def speed_lines(rows):
    """Speed ratio of ours against thesis_baseline: same scenario, same run."""
    med = {}
    for r in rows:
        # A method that produced no estimate at all says nothing about its speed.
        if int(r["estimates"]) > 0:
            med.setdefault(r["label"], {})[r["method"]] = float(r["median_ms"])
    out = []
    for label, m in med.items():
        if "ours" in m and "thesis_baseline" in m and m["ours"] > 0:
            out.append(f"speed {label}: thesis_baseline median {m['thesis_baseline']:.1f} ms / ours "
                       f"{m['ours']:.2f} ms = {m['thesis_baseline'] / m['ours']:.0f}x faster")
    return out


def print_text(rows):
    print("(sd x/y/z: spread of the estimated positions; for moving scenes it includes the motion)")
    widths = [24, 16, 8, 9, 8, 16, 8, 9, 9, 7, 7, 7, 7, 7, 7]
    left = 3  # the first three columns are left-aligned
    fmt = lambda vals: " ".join(v.ljust(w) if i < left else v.rjust(w)
                                for i, (v, w) in enumerate(zip(vals, widths)))
    print(fmt(COLUMNS))
    for r in rows:
        print(fmt(cells(r)))
    print()
    for line in speed_lines(rows):
        print(line)


def read_commands(path):
    """KIND NAME COMMAND lines (tab-separated), in order, without repeats."""
    seen, out = set(), []
    if path and os.path.exists(path):
        for line in open(path):
            parts = line.rstrip("\n").split("\t", 2)
            if len(parts) == 3 and tuple(parts) not in seen:
                seen.add(tuple(parts))
                out.append(parts)
    return out


def markdown(rows, args):
    cmds = read_commands(args.commands)
    md = [BEGIN, "## Benchmark (scripts/bench)", ""]
    md.append(f"Written by `{args.run}` on {args.header}.")
    md.append("")
    md.append(f"Bags: {args.duration} s of the thesis lab rig (six cameras at 30 Hz), seed 1, "
              "cropped SensorFrames, profile `kinect_v2_calibrated` (`kinect_v2_field` for "
              "`*_field`); default estimator configuration, one thread; thesis_baseline only on "
              f"its first {args.baseline_cycles} cycles.")
    md.append("")
    md.append("| " + " | ".join(COLUMNS) + " |")
    md.append("|" + "---|" * len(COLUMNS))
    for r in rows:
        md.append("| " + " | ".join(cells(r)) + " |")
    md.append("")
    for line in speed_lines(rows):
        md.append(f"- {line} (the two `bench_estimator` runs of that scenario below)")
    md += ["", "Commands behind each row (from the repository root, workspace sourced):", ""]
    for kind, name, cmd in cmds:
        if kind in ("bag", "estimate"):
            md.append(f"- {name} ({'bag' if kind == 'bag' else 'estimates'}): `{cmd}`")
    live = open(args.live).read().rstrip() if args.live and os.path.exists(args.live) else ""
    if args.repo:  # paths as seen from the repository root
        live = live.replace(args.repo.rstrip("/") + "/", "")
    if live:
        md += ["", "### Live replay at 1x through the node", ""]
        md.append("Six cameras at 30 Hz through the `pose_estimator` node (its default `threads`), "
                  "thesis_vertical; latency = publish time minus arrival of the cycle's last frame.")
        md.append("")
        for kind, name, cmd in cmds:
            if kind == "live":
                md.append(f"- `{cmd}`")
        md += ["", "```", live, "```"]
    md.append(END)
    return "\n".join(md) + "\n"


def splice(part, out_path, template_path):
    """The text of out_path (or of the template) with its marked part replaced by `part`."""
    for path in (out_path, template_path):
        if path and os.path.exists(path):
            text = open(path).read()
            if BEGIN in text and END in text:
                head, rest = text.split(BEGIN, 1)
                tail = rest.split(END, 1)[1]
                return head + part.rstrip("\n") + tail
    return "# Measured results\n\n" + part


def main():
    ap = argparse.ArgumentParser(description=__doc__,
                                 formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("results", help="file with bench_estimator's RESULT lines")
    ap.add_argument("--markdown", metavar="FILE", help="write the markdown results page here")
    ap.add_argument("--template", metavar="FILE", help="page to start from when FILE has no markers")
    ap.add_argument("--commands", metavar="FILE", help="KIND<TAB>NAME<TAB>COMMAND lines")
    ap.add_argument("--live", metavar="FILE", help="the live replay's evaluation output")
    ap.add_argument("--header", default="", help="date, machine and commit of the run")
    ap.add_argument("--run", default="scripts/bench", help="the bench command line")
    ap.add_argument("--duration", default="10", help="bag length [s]")
    ap.add_argument("--baseline-cycles", default="3", help="cycles of thesis_baseline")
    ap.add_argument("--repo", help="repository root, left out of the paths in --live's text")
    args = ap.parse_args()
    rows = parse(args.results)
    if not rows:
        print("no results")
        return 1
    print_text(rows)
    if args.markdown:
        text = splice(markdown(rows, args), args.markdown, args.template)
        with open(args.markdown, "w") as f:
            f.write(text)
    return 0


if __name__ == "__main__":
    sys.exit(main())
