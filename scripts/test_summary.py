#!/usr/bin/env python3
"""Counts test cases in a catkin test_results folder and prints 'N passed, N failed'.

gtest-*.xml and rosunit-*.xml hold the real test cases; a suite's errors outside any case (its
set-up raised) count as failures. A rostest-*.xml wrapper adds a failure only when the wrapper
itself failed (a node crashed, no result file): counted once, on top.
"""
import glob
import os
import sys
import xml.etree.ElementTree as ET


def cases(path):
    root = ET.parse(path).getroot()
    passed = failed = skipped = 0
    for tc in root.iter("testcase"):
        if tc.find("failure") is not None or tc.find("error") is not None:
            failed += 1
            print(f"  FAILED {tc.get('classname')}.{tc.get('name')} ({os.path.basename(path)})")
        elif tc.find("skipped") is not None or tc.get("status") == "notrun":
            skipped += 1
        else:
            passed += 1
    # An error outside any test case (a test class whose set-up raised: rosunit writes a suite
    # with errors="1" and no case) counts too.
    declared = sum(int(ts.get("errors", 0) or 0) + int(ts.get("failures", 0) or 0)
                   for ts in root.iter("testsuite"))
    if declared > failed:
        print(f"  FAILED {root.get('name')}: {declared - failed} error(s) outside any test case "
              f"({os.path.basename(path)})")
        failed = declared
    return passed, failed, skipped


def main(folder):
    passed = failed = skipped = 0
    files = sorted(glob.glob(os.path.join(folder, "*.xml")))
    if not files:
        print(f"no test results in {folder}")
        print("0 passed, 1 failed")
        return 1
    for f in files:
        p, fl, s = cases(f)
        if os.path.basename(f).startswith("rostest-"):
            failed += fl  # wrapper-level failure only; its passing case is not a test of ours
            continue
        passed, failed, skipped = passed + p, failed + fl, skipped + s
    line = f"{passed} passed, {failed} failed"
    if skipped:
        line += f", {skipped} skipped"
    print(line)
    return 0 if failed == 0 and passed > 0 else 1


if __name__ == "__main__":
    sys.exit(main(sys.argv[1]))
