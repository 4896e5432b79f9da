#!/usr/bin/env python3
"""Speed of two builds of bench_estimator on one bag, as the median of pairwise ratios.

    scripts/speed_ratio.py OLD_BENCH NEW_BENCH BAG [--new-bag BAG2] [--runs N] [-- OPTIONS]

--new-bag runs NEW on BAG2 (OLD stays on BAG): the cost of a change in the input, e.g. the same
build on bags of two sensor models (then OLD_BENCH and NEW_BENCH may be the same program).
--old-param / --new-param KEY=VALUE (repeatable) are given to one side only: the cost of a
setting, e.g. the same program with noise/amplitude_model=false and =true.

Runs OLD and NEW alternately N times (default 5) on BAG, single-threaded (--threads 1, or
--param threads=1 for a build that takes --param), reads each run's "time per cycle" line
(median and p95 [ms]) and prints every run's figures, the ratios new/old of each pair and their
medians. Machines are shared and noisy: only ratios of runs made back to back mean something.
Exit 2 on a usage error, 1 when a run fails.
"""
import argparse
import re
import statistics
import subprocess
import sys

LINE = re.compile(r"time per cycle \[ms\]: median ([0-9.]+), p95 ([0-9.]+)")


def threads_option(bench):
    out = subprocess.run([bench, "--help"], capture_output=True, text=True)
    return ["--param", "threads=1"] if "--param" in out.stdout + out.stderr else ["--threads", "1"]


def run(bench, bag, extra):
    out = subprocess.run([bench, bag, *threads_option(bench), *extra], capture_output=True,
                         text=True)
    m = LINE.search(out.stdout)
    if out.returncode != 0 or not m:
        sys.stderr.write(out.stdout + out.stderr)
        raise SystemExit(f"speed_ratio: {bench} failed on {bag} (rc {out.returncode})")
    return float(m.group(1)), float(m.group(2))


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("old")
    ap.add_argument("new")
    ap.add_argument("bag")
    ap.add_argument("--runs", type=int, default=5, help="pairs of runs (default 5)")
    ap.add_argument("--new-bag", help="the bag NEW runs on (default: BAG)")
    ap.add_argument("--old-param", action="append", default=[], metavar="KEY=VALUE",
                    help="a --param for OLD only (repeatable)")
    ap.add_argument("--new-param", action="append", default=[], metavar="KEY=VALUE",
                    help="a --param for NEW only (repeatable)")
    args, extra = ap.parse_known_args()
    if extra and extra[0] == "--":
        extra = extra[1:]
    args.extra = extra
    if args.runs < 1:
        ap.error("--runs must be >= 1")
    ratios_med, ratios_p95 = [], []
    for i in range(args.runs):
        old = run(args.old, args.bag, args.extra + [a for kv in args.old_param for a in ("--param", kv)])
        new = run(args.new, args.new_bag or args.bag,
                  args.extra + [a for kv in args.new_param for a in ("--param", kv)])
        ratios_med.append(new[0] / old[0])
        ratios_p95.append(new[1] / old[1])
        print(f"pair {i + 1}: old median {old[0]:.2f} p95 {old[1]:.2f} ms | new median "
              f"{new[0]:.2f} p95 {new[1]:.2f} ms | ratio {ratios_med[-1]:.3f} / {ratios_p95[-1]:.3f}",
              flush=True)
    print(f"median of pairwise ratios new/old ({args.runs} pairs): median per cycle "
          f"{statistics.median(ratios_med):.3f}, p95 per cycle {statistics.median(ratios_p95):.3f}")


if __name__ == "__main__":
    main()
