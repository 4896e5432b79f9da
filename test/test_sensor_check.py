#!/usr/bin/env python3
"""Guards the sensor_check measurement procedure on the real-data subset in test/data.

    /usr/bin/python3 test/test_sensor_check.py        (plain unittest; numpy, PyYAML, cv2)

test/data/kinect_cal_subset holds 7 unchanged frames of a real Kinect v2 (see its README) from
0.63 to 1.51 m. Each measure of each frame must stay within a band around the value measured
when the procedure was written (docs/sensor_check.md). The input is fixed, so only numerical
differences (OpenCV / numpy versions: solvePnP's iterations, undistortion) can move a value
legitimately. The bands are about twice the largest change that jittering every corner by
0.05 px (normal, 5 draws) caused on these frames, which exceeds any such numerical difference;
a change of the procedure (window margin, outlier rule, pixel selection, binning) moves at
least one measure by more (see test_band_catches_a_procedure_change).
"""
import io
import os
import subprocess
import sys
import unittest
from contextlib import redirect_stdout

import numpy as np

HERE = os.path.dirname(os.path.abspath(__file__))
ROOT = os.path.dirname(HERE)
sys.path.insert(0, os.path.join(ROOT, "scripts"))
import sensor_check_lib as lib  # noqa: E402

DATA = os.path.join(HERE, "data", "kinect_cal_subset")
TOOL = os.path.join(ROOT, "scripts", "sensor_check")

# Measured with the procedure as committed (None: no pixel of that kind, e.g. every bright
# square saturated).
EXPECTED = {
    "0000": dict(dist_m=0.6512, resid_std=3.537, bright_sd=1.315, dark_sd=2.501, corr_sq=0.5812, corr_plane=0.6499, dark_minus_bright=1.371, inv_bright=0.6192, inv_dark=0, pnp_offset=-15.59),
    "0007": dict(dist_m=0.627, resid_std=3.649, bright_sd=None, dark_sd=1.975, corr_sq=0.5612, corr_plane=0.6543, dark_minus_bright=None, inv_bright=1, inv_dark=0, pnp_offset=-11.23),
    "0008": dict(dist_m=0.6269, resid_std=3.632, bright_sd=None, dark_sd=1.964, corr_sq=0.5576, corr_plane=0.6694, dark_minus_bright=None, inv_bright=1, inv_dark=0, pnp_offset=-11.54),
    "0017": dict(dist_m=0.9978, resid_std=2.961, bright_sd=1.412, dark_sd=2.336, corr_sq=0.4996, corr_plane=0.6257, dark_minus_bright=-3.782, inv_bright=0.001721, inv_dark=0, pnp_offset=-28.46),
    "0025": dict(dist_m=1.2, resid_std=6.122, bright_sd=1.392, dark_sd=6.116, corr_sq=0.5312, corr_plane=0.6488, dark_minus_bright=7.072, inv_bright=0, inv_dark=0, pnp_offset=-43.55),
    "0026": dict(dist_m=1.252, resid_std=6.979, bright_sd=1.511, dark_sd=6.389, corr_sq=0.5453, corr_plane=0.7015, dark_minus_bright=11.2, inv_bright=0, inv_dark=0, pnp_offset=-47.14),
    "0101": dict(dist_m=1.511, resid_std=3.028, bright_sd=1.541, dark_sd=2.835, corr_sq=0.374, corr_plane=0.691, dark_minus_bright=-3.776, inv_bright=0, inv_dark=0, pnp_offset=-56.64),
}
# Repeated pose 0007 + 0008 (corners within 0.28 px).
EXPECTED_TEMPORAL = dict(temporal_sd=1.981, temporal_corr=0.5859, pixels=4665)
EXPECTED_DEPTH_SHIFT = 23.33      # pixel-pooled mean(z_pnp - z) over the subset [mm]
EXPECTED_SLOPE = -52.0            # offset growth with range over the subset [mm/m]


def band(key, value):
    """Allowed deviation for a measure (see the module docstring)."""
    if key == "dist_m":
        return 0.005                                   # m
    if key in ("resid_std", "bright_sd", "dark_sd", "temporal_sd"):
        return 0.02 * abs(value) + 0.02                # mm (jitter: <= 1.5 % )
    if key in ("corr_sq", "corr_plane", "temporal_corr"):
        return 0.01                                    # (jitter: <= 0.005)
    if key == "dark_minus_bright":
        return 0.3                                     # mm (jitter: <= 0.17)
    if key in ("inv_bright", "inv_dark"):
        return 0.005                                   # fraction
    if key == "pnp_offset":
        return 3.0                                     # mm (jitter: <= 2.4 at 1.5 m)
    raise KeyError(key)


def within(test, measured, expected, where):
    for key, want in expected.items():
        got = measured[key]
        if want is None:
            test.assertTrue(not np.isfinite(got), f"{where} {key}: expected no value, got {got}")
            continue
        test.assertTrue(np.isfinite(got), f"{where} {key}: no value, expected {want}")
        tol = band(key, want)
        test.assertLessEqual(abs(got - want), tol,
                             f"{where} {key}: {got:.4g} outside {want} +- {tol:.3g}")


class SensorCheckOnSubset(unittest.TestCase):
    @classmethod
    def setUpClass(cls):
        cls.res = lib.run_folder(DATA)

    def test_dark_squares_from_ir(self):
        self.assertEqual(self.res["votes"], (0, 1))
        self.assertEqual(self.res["dark_parity"], 1)

    def test_every_frame_measured(self):
        self.assertEqual(sorted(r["frame"] for r in self.res["results"]), sorted(EXPECTED))
        self.assertEqual(self.res["excluded"], [])
        for r in self.res["results"]:
            self.assertLess(r["reproj_px"], 0.3, r["frame"])

    def test_measures_within_bands(self):
        for r in self.res["results"]:
            within(self, r, EXPECTED[r["frame"]], r["frame"])

    def test_temporal_on_repeated_pose(self):
        self.assertEqual(len(self.res["temporal"]), 1)
        d, t = self.res["temporal"][0]
        self.assertEqual(t["frames_names"], ["0007", "0008"])
        self.assertEqual(t["pixels"], EXPECTED_TEMPORAL["pixels"])
        within(self, t, {k: EXPECTED_TEMPORAL[k] for k in ("temporal_sd", "temporal_corr")}, "0007+0008")

    def test_offset_against_pnp(self):
        shift = lib.pooled_depth_shift(self.res["results"])
        self.assertLessEqual(abs(shift - EXPECTED_DEPTH_SHIFT), 2.0)
        # Same sign and size as the upstream tool's depthShift for this device (25.49 mm).
        self.assertLessEqual(abs(shift - lib.read_depth_shift(os.path.join(DATA, "calib_depth.yaml"))), 5.0)
        _, slope, n = lib.offset_vs_range(self.res["results"])
        self.assertEqual(n, len(EXPECTED))
        self.assertLessEqual(abs(slope - EXPECTED_SLOPE), 5.0)

    def test_band_catches_a_procedure_change(self):
        """A narrower window margin or a tighter outlier rule leaves some measure out of band."""
        depth, corners, _ = lib.load_frame(DATA, "0026")
        saved = lib.WINDOW_MARGIN, lib.OUTLIER_K
        try:
            for margin, k in ((0.1, lib.OUTLIER_K), (lib.WINDOW_MARGIN, 2.5)):
                lib.WINDOW_MARGIN, lib.OUTLIER_K = margin, k
                r = lib.measure_frame(depth, self.res["K"], self.res["dist"], corners, lib.Board(), 1)
                outside = [key for key, want in EXPECTED["0026"].items()
                           if want is not None and abs(r[key] - want) > band(key, want)]
                self.assertTrue(outside, f"margin {margin}, K {k}: every measure still in band")
        finally:
            lib.WINDOW_MARGIN, lib.OUTLIER_K = saved

    def test_misplaced_corner_is_left_out(self):
        depth, corners, _ = lib.load_frame(DATA, "0017")
        bad = corners.copy()
        bad[34] += 6.0
        r = lib.measure_frame(depth, self.res["K"], self.res["dist"], bad, lib.Board(), 1)
        self.assertGreater(r["reproj_px"], lib.MAX_REPROJ_PX)

    def test_corner_order_checked(self):
        depth, corners, _ = lib.load_frame(DATA, "0017")
        swapped = corners.reshape(7, 5, 2).transpose(1, 0, 2).reshape(-1, 2)   # column-major
        with self.assertRaises(ValueError):
            lib.measure_frame(depth, self.res["K"], self.res["dist"], swapped, lib.Board(), 1)


class SensorCheckCommandLine(unittest.TestCase):
    def run_tool(self, *args):
        return subprocess.run([sys.executable, TOOL, *args], capture_output=True, text=True)

    def test_help(self):
        p = self.run_tool("--help")
        self.assertEqual(p.returncode, 0)
        for opt in ("DATA_DIR", "--board", "--dark-parity", "--repeat-px", "--calib", "--markdown",
                    "--frames-csv"):
            self.assertIn(opt, p.stdout)

    def test_bad_options_exit_2(self):
        for args in (["--no-such-option", DATA], ["--board", "5x7", DATA], ["--repeat-px", "-1", DATA],
                     ["--dark-parity", "2", DATA], []):
            self.assertEqual(self.run_tool(*args).returncode, 2, args)

    def test_missing_data_exit_1(self):
        self.assertEqual(self.run_tool(os.path.join(DATA, "no_such_dir")).returncode, 1)

    def test_joint_intrinsics(self):
        p = self.run_tool(DATA, "--no-procedure", "--joint-intrinsics")
        self.assertEqual(p.returncode, 0, p.stderr)
        self.assertIn("IR intrinsics fitted jointly on the 7 measured frames' corners", p.stdout)
        self.assertIn("IR intrinsics (fitted jointly, below)", p.stdout)

    def test_table(self):
        p = self.run_tool(DATA)
        self.assertEqual(p.returncode, 0, p.stderr)
        self.assertIn("Procedure (this text is the definition", p.stdout)
        self.assertIn("Dark squares: (i + j) % 2 == 1", p.stdout)
        rows = {ln.split()[0]: ln.split() for ln in p.stdout.splitlines()
                if ln.strip()[:4] in ("0.50", "0.75", "1.00", "1.25", "1.50")}
        self.assertEqual({k: v[1] for k, v in rows.items()},
                         {"0.50-0.75": "3", "0.75-1.00": "1", "1.00-1.25": "1", "1.25-1.50": "1",
                          "1.50-1.75": "1"})
        self.assertIn("Repeated pose 0007+0008", p.stdout)


if __name__ == "__main__":
    # ctest (CMakeLists.txt): test_sensor_check.py --xml OUT.xml; alone: no arguments.
    sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
    from junit_result import run_suite
    xml = sys.argv[2] if len(sys.argv) == 3 and sys.argv[1] == "--xml" else None
    sys.exit(run_suite(unittest.defaultTestLoader.loadTestsFromModule(sys.modules[__name__]),
                       "sensor_check", xml))
