#!/usr/bin/env python3
"""Side-by-side accuracy of two scripts/bench runs (e.g. two sensor models), as markdown.

    scripts/model_compare.py BEFORE.md AFTER.md [--labels "before fit" "fitted"]

BEFORE.md and AFTER.md are files scripts/bench wrote (its first table: scenario, method, end,
valid, mean mm, sd, axis deg, <=1cm1deg, <=2cm2deg, in 3sig, ...). Prints, for every row of
method `ours` present in both: mean error, axis error, the share within 1 cm / 1 deg, the share
inside the reported 3-sigma ellipsoid and the median time per cycle, before -> after.
Exit status 0; 1 when a file has no bench table; 2 on a bad command line.
"""
import argparse
import sys


def read_table(path):
    """{(scenario, end): {column: cell}} of the rows of method `ours` in the first bench table."""
    rows, head = {}, None
    with open(path) as f:
        for line in f:
            if not line.startswith("| "):
                if head and rows:
                    break
                continue
            cells = [c.strip() for c in line.strip().strip("|").split("|")]
            if cells[:3] == ["scenario", "method", "end"]:
                head = cells
                continue
            if head is None or set(line.replace("|", "").strip()) <= set("-: "):
                continue
            row = dict(zip(head, cells))
            if row.get("method") == "ours":
                rows[(row["scenario"], row["end"])] = row
    if not rows:
        raise ValueError(f"{path}: no bench table with rows of method 'ours'")
    return rows


COLUMNS = [("mean mm", "mean error mm"), ("axis deg", "axis error deg"),
           ("<=1cm1deg", "within 1 cm / 1 deg"), ("in 3sig", "inside 3-sigma"), ("med ms", "median ms")]


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("before")
    ap.add_argument("after")
    ap.add_argument("--labels", nargs=2, default=["before", "after"], metavar=("BEFORE", "AFTER"))
    a = ap.parse_args(argv)
    try:
        b, n = read_table(a.before), read_table(a.after)
    except (OSError, ValueError) as e:
        print(f"model_compare: {e}", file=sys.stderr)
        return 1
    print(f"Each cell: {a.labels[0]} -> {a.labels[1]}.")
    print()
    print("| scenario | end | " + " | ".join(h for _, h in COLUMNS) + " |")
    print("|---|---|" + "---|" * len(COLUMNS))
    for key in b:
        if key not in n:
            continue
        cells = [f"{b[key].get(c, '-')} -> {n[key].get(c, '-')}" for c, _ in COLUMNS]
        print(f"| {key[0]} | {key[1]} | " + " | ".join(cells) + " |")
    return 0


if __name__ == "__main__":
    sys.exit(main())
