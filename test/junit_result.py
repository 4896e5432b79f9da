"""Runs a unittest suite and writes its result as a JUnit file (for scripts/test's summary)."""
import os
import unittest
import xml.etree.ElementTree as ET


def _tests(suite):
    for t in suite:
        if isinstance(t, unittest.TestSuite):
            yield from _tests(t)
        else:
            yield t


def run_suite(suite, name, xml_path=None):
    """Runs `suite` (verbose), writes the JUnit file `xml_path` when given; 0 when it passed."""
    ids = [t.id() for t in _tests(suite)]  # the suite forgets its tests once run
    result = unittest.TextTestRunner(verbosity=2).run(suite)
    if xml_path:
        bad = {}  # test id -> messages (a failed subTest counts against its test)
        for t, msg in result.failures + result.errors:
            tid = getattr(t, "test_case", t).id()
            bad[tid] = bad.get(tid, "") + msg
        root = ET.Element("testsuite", name=name, tests=str(result.testsRun),
                          failures=str(len(bad)), errors="0", time="0")
        for tid in ids:
            tc = ET.SubElement(root, "testcase", classname=tid.split(".")[-2],
                               name=tid.split(".")[-1], time="0")
            if tid in bad:
                ET.SubElement(tc, "failure", message="failed").text = bad[tid]
        os.makedirs(os.path.dirname(os.path.abspath(xml_path)), exist_ok=True)
        ET.ElementTree(root).write(xml_path, encoding="utf-8", xml_declaration=True)
    return 0 if result.wasSuccessful() else 1
