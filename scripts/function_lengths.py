#!/usr/bin/env python3
"""Lists the longest functions in src/ (universal-ctags end lines, so a lambda counts toward the
function that holds it) and fails when one is over the limit without a comment saying why.

    scripts/function_lengths.py [--top N] [--limit LINES] [ROOT]

A function may be longer than the limit when one of the three lines above its definition holds a
comment with the words "lines because" (for example "// Over 120 lines because ...").
Exit 0 when every long function is explained, 1 otherwise, 2 on a usage error.
"""
import argparse
import json
import os
import subprocess
import sys


def functions(root):
    out = subprocess.run(
        ["ctags", "--output-format=json", "--fields=+ne", "--kinds-C++=f", "--languages=C++",
         "-R", "-f", "-", os.path.join(root, "src")],
        check=True, capture_output=True, text=True).stdout
    for line in out.splitlines():
        tag = json.loads(line)
        if tag.get("_type") != "tag" or "end" not in tag:
            continue
        scope = tag.get("scope", "")
        name = f"{scope}::{tag['name']}" if scope else tag["name"]
        yield tag["end"] - tag["line"] + 1, os.path.relpath(tag["path"], root), tag["line"], name


def explained(path, line):
    with open(path, encoding="utf-8") as f:
        lines = f.readlines()
    above = lines[max(0, line - 4):line - 1]
    return any("//" in l and "lines because" in l for l in above)


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("root", nargs="?", default=os.path.join(os.path.dirname(__file__), ".."))
    ap.add_argument("--top", type=int, default=10, help="how many to list (default 10)")
    ap.add_argument("--limit", type=int, default=120, help="longest allowed (default 120)")
    args = ap.parse_args()
    root = os.path.abspath(args.root)
    funcs = sorted(functions(root), reverse=True)
    print(f"longest functions in src/ (of {len(funcs)}):")
    for n, path, line, name in funcs[:args.top]:
        print(f"  {n:4d} lines  {path}:{line}  {name}")
    bad = [f for f in funcs if f[0] > args.limit and not explained(os.path.join(root, f[1]), f[2])]
    for n, path, line, name in bad:
        print(f"ERROR: {path}:{line} {name} is {n} lines (> {args.limit}) with no comment saying why")
    return 1 if bad else 0


if __name__ == "__main__":
    sys.exit(main())
