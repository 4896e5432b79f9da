#!/usr/bin/env python3
"""Summarises the RESULT lines of bench_estimator into the bench table (scripts/bench)."""
import sys


def parse(path):
    rows = []
    for line in open(path):
        if not line.startswith("RESULT "):
            continue
        kv = dict(f.split("=", 1) for f in line.split()[1:])
        rows.append(kv)
    return rows


def main(path):
    rows = parse(path)
    if not rows:
        print("no results")
        return 1
    print("(sd x/y/z: spread of the estimated positions; for moving scenes it includes the motion)")
    hdr = (f"{'scenario':24s} {'method':16s} {'end':8s} {'valid':>9s} {'mean mm':>8s} "
           f"{'sd x/y/z mm':>16s} {'axis deg':>8s} {'<=1cm1deg':>9s} {'<=2cm2deg':>9s} "
           f"{'in 3sig':>7s} {'ax 3sig':>7s} {'med ms':>7s} {'p95 ms':>7s} {'p99 ms':>7s} "
           f"{'RSS MB':>7s}")
    print(hdr)
    for r in rows:
        sd = f"{float(r['std_x_mm']):.1f}/{float(r['std_y_mm']):.1f}/{float(r['std_z_mm']):.1f}"
        print(f"{r['label']:24s} {r['method']:16s} {r['end']:8s} "
              f"{r['estimates']:>4s}/{r['expected']:<4s} {float(r['mean_err_mm']):8.1f} {sd:>16s} "
              f"{float(r['mean_axis_deg']):8.2f} {100 * float(r['within_1cm_1deg']):8.1f}% "
              f"{100 * float(r['within_2cm_2deg']):8.1f}% {100 * float(r['in_3sigma']):6.1f}% "
              f"{100 * float(r.get('axis_in_3sigma', 'nan')):6.1f}% "
              f"{float(r['median_ms']):7.2f} {float(r['p95_ms']):7.1f} {float(r['p99_ms']):7.1f} "
              f"{float(r['rss_mb']):7.1f}")
    # Speed ratio: same scenario, same run.
    med = {}
    for r in rows:
        # A method that produced no estimate at all says nothing about its speed.
        if int(r["estimates"]) > 0:
            med.setdefault(r["label"], {})[r["method"]] = float(r["median_ms"])
    print()
    for label, m in med.items():
        if "ours" in m and "thesis_baseline" in m and m["ours"] > 0:
            print(f"speed {label}: thesis_baseline median {m['thesis_baseline']:.1f} ms / ours "
                  f"{m['ours']:.2f} ms = {m['thesis_baseline'] / m['ours']:.0f}x faster")
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1]))
