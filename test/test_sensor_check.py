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
import sensor_edge_lib as edgelib  # noqa: E402

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
# The board's silhouette (sensor_edge_lib), measured with the procedure as committed.
EXPECTED_EDGES = {
    "0000": dict(edge_crossings=208, mixed_per_cross=0.1346, invalid_per_cross=0.6538, edge_sd_px=0.4186, mixed_t_median=0.06811, edge_back_mm=1100),
    "0007": dict(edge_crossings=137, mixed_per_cross=0.562, invalid_per_cross=0.8029, edge_sd_px=0.3699, mixed_t_median=0.0546, edge_back_mm=334.9),
    "0008": dict(edge_crossings=133, mixed_per_cross=0.5113, invalid_per_cross=0.8947, edge_sd_px=0.3646, mixed_t_median=0.06312, edge_back_mm=335),
    "0017": dict(edge_crossings=151, mixed_per_cross=0.6821, invalid_per_cross=1.265, edge_sd_px=0.6016, mixed_t_median=0.1293, edge_back_mm=913.5),
    "0025": dict(edge_crossings=146, mixed_per_cross=0.4795, invalid_per_cross=1.445, edge_sd_px=0.3684, mixed_t_median=0.2112, edge_back_mm=217.7),
    "0026": dict(edge_crossings=154, mixed_per_cross=0.6039, invalid_per_cross=1.318, edge_sd_px=0.4266, mixed_t_median=0.3765, edge_back_mm=220.5),
    "0101": dict(edge_crossings=130, mixed_per_cross=1.0, invalid_per_cross=1.469, edge_sd_px=0.6372, mixed_t_median=0.188, edge_back_mm=217.4),
}
EXPECTED_TEMPORAL_EDGE_SD = 0.3676   # px, 0007 + 0008
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
    # Edge measures count pixels along crossings placed by the PnP pose: a numerical change of
    # the pose can move a crossing's pixels, so the bands allow a few crossings to change.
    if key == "edge_crossings":
        return 0.03 * value + 2
    if key in ("mixed_per_cross", "invalid_per_cross"):
        return 0.05
    if key in ("edge_sd_px", "mixed_t_median"):
        return 0.03
    if key == "edge_back_mm":
        return 0.02 * value
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

    def test_edges_within_bands(self):
        edgelib.add_edges(lambda n: lib.load_frame(DATA, n)[:2], self.res["results"], self.res["temporal"],
                          self.res["K"], self.res["dist"])
        for r in self.res["results"]:
            within(self, r, EXPECTED_EDGES[r["frame"]], r["frame"] + " edges")
        t = self.res["temporal"][0][1]
        self.assertLessEqual(abs(t["temporal_edge_sd_px"] - EXPECTED_TEMPORAL_EDGE_SD), 0.03)

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
                    "--frames-csv", "--fit-edges", "--edges-before-refit", "--sensor-param"):
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
        rows = {}
        for ln in p.stdout.splitlines():   # the first table's rows (the edge table follows)
            if ln.strip()[:4] in ("0.50", "0.75", "1.00", "1.25", "1.50"):
                rows.setdefault(ln.split()[0], ln.split())
        self.assertEqual({k: v[1] for k, v in rows.items()},
                         {"0.50-0.75": "3", "0.75-1.00": "1", "1.00-1.25": "1", "1.25-1.50": "1",
                          "1.50-1.75": "1"})
        self.assertIn("Repeated pose 0007+0008", p.stdout)
        self.assertIn("Edge procedure (the board's silhouette", p.stdout)
        self.assertIn("Edges of the board", p.stdout)


class EdgeMeasuresOnASyntheticBoard(unittest.TestCase):
    """A board drawn exactly (pinhole, no noise) before a wall 0.2 m behind it: the measure must
    find no mixed and no invalid pixel and a straight edge; with every board pixel at the
    silhouette invalid, or moved halfway to the wall, it must count them."""

    K = np.array([[365.0, 0, 256.0], [0, 365.0, 212.0], [0, 0, 1]])
    DIST = np.zeros(5)

    def board_frame(self):
        board = lib.Board()
        R = cv2_rotation([0.25, -0.2, 0.05])
        t = np.array([-0.06, -0.09, 1.0])
        rays = lib.pixel_rays((424, 512), self.K, self.DIST)
        u, v, zp = lib.board_coords(rays, R, t)
        on = (u > -0.06) & (u < 0.21) & (v > -0.06) & (v < 0.27)
        r3 = np.concatenate([rays, np.ones(rays.shape[:2] + (1,))], axis=-1)
        n, d = R[:, 2], float(R[:, 2] @ t)
        z_wall = (d + 0.2) / (r3 @ n)                    # a plane parallel to the board, 0.2 m behind
        depth = np.where(on, zp, z_wall) * 1000.0
        corners, _ = cv2_project(board.object_points(), R, t, self.K)
        edge = on & ~(np.roll(on, 1, 0) & np.roll(on, -1, 0) & np.roll(on, 1, 1) & np.roll(on, -1, 1))
        return depth, corners, edge, zp, z_wall

    def test_clean_edge(self):
        depth, corners, _, _, _ = self.board_frame()
        m = edgelib.measure_edges(np.round(depth).astype(np.uint16), self.K, self.DIST, corners)
        self.assertGreater(m["edge_crossings"], 300)      # 332: about one per pixel of the sides
        self.assertEqual(m["edge_sides"], 4)
        self.assertEqual(m["mixed_per_cross"], 0.0)
        self.assertEqual(m["invalid_per_cross"], 0.0)
        self.assertLess(m["edge_sd_px"], 0.35)            # the pixel grid alone
        self.assertAlmostEqual(m["edge_back_mm"], 200 / np.cos(np.radians(18)), delta=25)

    def test_invalid_and_mixed_edge_pixels_counted(self):
        depth, corners, edge, zp, z_wall = self.board_frame()
        bad = depth.copy()
        bad[edge] = 0
        m = edgelib.measure_edges(np.round(bad).astype(np.uint16), self.K, self.DIST, corners)
        self.assertGreater(m["invalid_per_cross"], 0.9)
        self.assertEqual(m["mixed_per_cross"], 0.0)
        mixed = depth.copy()
        mixed[edge] = 500.0 * (zp[edge] + z_wall[edge])
        m = edgelib.measure_edges(np.round(mixed).astype(np.uint16), self.K, self.DIST, corners)
        self.assertGreater(m["mixed_share"], 0.9)
        self.assertAlmostEqual(m["mixed_t_median"], 0.5, delta=0.05)


def cv2_rotation(rvec):
    import cv2
    return cv2.Rodrigues(np.array(rvec, float))[0]


def cv2_project(points, R, t, K):
    import cv2
    img, _ = cv2.projectPoints(points, cv2.Rodrigues(R)[0], t, K, np.zeros(5))
    return img.reshape(-1, 2), None


if __name__ == "__main__":
    # ctest (CMakeLists.txt): test_sensor_check.py --xml OUT.xml; alone: no arguments.
    sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
    from junit_result import run_suite
    xml = sys.argv[2] if len(sys.argv) == 3 and sys.argv[1] == "--xml" else None
    sys.exit(run_suite(unittest.defaultTestLoader.loadTestsFromModule(sys.modules[__name__]),
                       "sensor_check", xml))
