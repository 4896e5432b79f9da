#!/usr/bin/env python3
"""Guards the simulator's fitted sensor model against the real frames in test/data.

    /usr/bin/python3 test/test_sensor_sim.py --bin-dir .ws/devel/lib/drill_pipe_pose

Renders the 7 real poses of test/data/kinect_cal_subset with render_board (the simulator's own
depth effects, profile kinect_v2_calibrated, seed 1), with the amplitude laws fitted on the full
recording (test/data/kinect_cal_subset/sensor_fit.json, written by
`scripts/sensor_check DATA --fit --save-fit ...`), measures them like the real frames
(scripts/sensor_check_lib.py) and compares, per measure, the median over the frames of
sim / real (spreads) or sim - real (correlation, bias, invalid fractions).

The bands are the issue's targets (sim/real 0.8-1.25, correlation within 0.1, invalid fractions
within 10 points) where the full recording meets them in every bin; for the two measures it
does not meet (docs/sensor_check.md), the band is the one reached, so that the model cannot
drift away from the data unseen:
  plane sd     0.40-1.25: the real plane-fit spread holds a component stable over time and
               neither fixed to the board nor to the pixels that the model lacks
               (full recording: 0.49-0.90 by bin; the subset's median 0.73);
  dark-bright  within 5 mm (full recording: within 1.2 mm below 1.25 m, -2.9 mm at 1.25-1.5 m;
               the subset's median +4.0 mm).
The model before the fit (white noise, no amplitude effects) fails every band but the bright
spread and the dark-square invalid fraction (test_old_model_fails).
"""
import argparse
import os
import sys
import tempfile
import unittest

import numpy as np

HERE = os.path.dirname(os.path.abspath(__file__))
ROOT = os.path.dirname(HERE)
sys.path.insert(0, os.path.join(ROOT, "scripts"))
import sensor_check_lib as lib  # noqa: E402
import sensor_fit_lib as fitlib  # noqa: E402

DATA = os.path.join(HERE, "data", "kinect_cal_subset")
FIT = os.path.join(DATA, "sensor_fit.json")
BIN_DIR = os.path.join(ROOT, ".ws", "devel", "lib", "drill_pipe_pose")
SEED = 1

# measure: (kind, low, high)
BANDS = {
    "resid_std": ("ratio", 0.40, 1.25),
    "bright_sd": ("ratio", 0.80, 1.25),
    "dark_sd": ("ratio", 0.80, 1.25),
    "corr_sq": ("diff", -0.10, 0.10),
    "dark_minus_bright": ("diff", -5.0, 5.0),
    "inv_bright": ("diff", -0.10, 0.10),
    "inv_dark": ("diff", -0.10, 0.10),
}
TEMPORAL_BAND = (0.80, 1.25)
# The effects the fit added; switched off, the model is the one before the fit.
FITTED_EFFECTS = ("amplitude_noise", "correlated_noise", "brightness_bias", "saturation")


def compare(off=()):
    """Median over the frames of sim/real or sim - real per measure, and the temporal ratio."""
    res = lib.run_folder(DATA)
    fit = fitlib.load_fit(FIT)
    tool = os.path.join(BIN_DIR, "render_board")
    with tempfile.TemporaryDirectory() as tmp:
        sim, sim_temporal = fitlib.simulate_frames(tool, res, fit, tmp, seed=SEED, off=off)
    out = {}
    for key, (kind, _, _) in BANDS.items():
        vals = []
        for r, s in zip(res["results"], sim):
            a, b = r[key], s[key]
            if not (np.isfinite(a) and np.isfinite(b)):
                continue
            vals.append(b / a if kind == "ratio" else b - a)
        out[key] = float(np.median(vals))
    out["temporal_sd"] = sim_temporal[0][1]["temporal_sd"] / res["temporal"][0][1]["temporal_sd"]
    return out


def misses(values):
    bad = {k: v for k, v in values.items() if k in BANDS and not BANDS[k][1] <= v <= BANDS[k][2]}
    if not TEMPORAL_BAND[0] <= values["temporal_sd"] <= TEMPORAL_BAND[1]:
        bad["temporal_sd"] = values["temporal_sd"]
    return bad


class SensorSimTest(unittest.TestCase):
    def test_fitted_model_within_bands(self):
        values = compare()
        self.assertEqual(misses(values), {}, f"seed {SEED}; all medians: {values}")

    def test_old_model_fails(self):
        values = compare(off=FITTED_EFFECTS)
        bad = misses(values)
        for key in ("resid_std", "dark_sd", "corr_sq", "temporal_sd"):
            self.assertIn(key, bad, f"seed {SEED}; without the fitted effects: {values}")


if __name__ == "__main__":
    ap = argparse.ArgumentParser()
    ap.add_argument("--bin-dir", default=BIN_DIR)
    ap.add_argument("--xml")
    a = ap.parse_args()
    BIN_DIR = a.bin_dir
    sys.path.insert(0, HERE)
    from junit_result import run_suite
    sys.exit(run_suite(unittest.defaultTestLoader.loadTestsFromModule(sys.modules[__name__]),
                       "sensor_sim", a.xml))
