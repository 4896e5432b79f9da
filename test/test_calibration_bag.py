#!/usr/bin/env python3
"""rostest: a rig calibration from a recorded bag to the rig file, through ROS.

1. simulate_bag --hd-mono --fps 2 renders a short calibration (test/data/calibration_short.yaml:
   6 placements that all six cameras see, held 1.5 s, moved 0.5 s) as the rig's drivers would
   publish it; rosbag play sends it to launch/calibrate.launch (the recorder), stopped with
   SIGINT as a person stops it with Ctrl-C.
2. calibrate_rig --bag on the recording with config/calibration/thesis_lab.yaml: it succeeds and
   every camera is within POSITION_LIMIT of the true rig (simulate_bag --true-rig).
3. A short thesis_vertical bag replayed through launch/replay.launch with the calibrated rig:
   poses are published.
"""
import os
import re
import shutil
import signal
import subprocess
import sys
import tempfile
import time
import unittest

import rosbag
import rosgraph
import rospy
import rostest
import yaml
from drill_pipe_pose.msg import PipeEnds

PKG = "drill_pipe_pose"
SEED = 73
CAMERAS = [f"cam{i}" for i in range(1, 7)]
# [m] largest camera position error after the best rigid alignment: 4.9 mm measured on seed 73
# (6 placements that face up, 2 frames/s; 30 varied placements give about 1 mm); the limit leaves
# room for other machines' floating point, not for a wrong grouping (centimetres).
POSITION_LIMIT = 0.008
# [m] the anchoring error (the calibrated world against the true one): 6.1 mm measured on seed 73.
ANCHOR_LIMIT = 0.012


def tool(name):
    out = subprocess.run(["catkin_find", "--first-only", PKG, name], capture_output=True, text=True)
    path = out.stdout.strip()
    if not path:
        raise RuntimeError(f"cannot find the {name} tool (catkin_find {PKG} {name})")
    return path


def share():
    return subprocess.run(["rospack", "find", PKG], capture_output=True, text=True).stdout.strip()


def wait_for_subscriber(topic, timeout, process):
    """Waits until some node subscribes to `topic` (the recorder is up) while `process` runs."""
    master = rosgraph.Master("/test_calibration_bag")
    end = time.monotonic() + timeout
    while time.monotonic() < end and process.poll() is None:
        _, subs, _ = master.getSystemState()
        if any(t == topic for t, _ in subs):
            return True
        time.sleep(0.2)
    return False


class CalibrationBag(unittest.TestCase):
    @classmethod
    def setUpClass(cls):
        rospy.init_node("test_calibration_bag")
        cls.tmp = tempfile.mkdtemp(prefix="dpp_calibration_")
        cls.sim_bag = os.path.join(cls.tmp, "sim.bag")
        cls.true_rig = os.path.join(cls.tmp, "true_rig.yaml")
        cls.recorded = os.path.join(cls.tmp, "recorded.bag")
        cls.rig = os.path.join(cls.tmp, "calibrated_rig.yaml")
        t0 = time.monotonic()
        # 6 placements x (1.5 s + 0.5 s) - the last move.
        subprocess.run([tool("simulate_bag"), "--scene", f"{share()}/test/data/calibration_short.yaml",
                        "--duration", "11.5", "--seed", str(SEED), "--hd-mono", "--fps", "2",
                        "--quiet", "--true-rig", cls.true_rig, "--out", cls.sim_bag], check=True)
        print(f"simulate_bag: {time.monotonic() - t0:.1f} s, "
              f"{os.path.getsize(cls.sim_bag) / 1e6:.1f} MB", flush=True)

    @classmethod
    def tearDownClass(cls):
        shutil.rmtree(cls.tmp, ignore_errors=True)  # two 300 MB bags

    def test_1_record_calibrate_replay(self):
        self.record()
        self.calibrate()
        self.replay()

    def record(self):
        t0 = time.monotonic()
        launch = subprocess.Popen(["roslaunch", PKG, "calibrate.launch", f"bag:={self.recorded}"])
        try:
            self.assertTrue(wait_for_subscriber("/cam6/sd/camera_info", 30.0, launch),
                            "calibrate.launch exited or its recorder did not subscribe to /cam6/sd/camera_info within 30 s")
            time.sleep(1.0)
            subprocess.run(["rosbag", "play", "-q", self.sim_bag], check=True)
            time.sleep(2.0)
        finally:
            launch.send_signal(signal.SIGINT)
            launch.wait(timeout=30)
        with rosbag.Bag(self.recorded) as bag:
            info = bag.get_type_and_topic_info().topics
        sets = {c: info.get(f"/{c}/hd/image_mono_rect").message_count
                if f"/{c}/hd/image_mono_rect" in info else 0 for c in CAMERAS}
        print(f"recorder: {time.monotonic() - t0:.1f} s, sets {sets}, "
              f"{os.path.getsize(self.recorded) / 1e6:.1f} MB", flush=True)
        self.sets = sets
        self.assertIn("/tf_static", info, "the recording has no /tf_static")
        for c in CAMERAS:  # 11.5 s at 2 frames/s: 23 sets; a few lost at the edges are fine
            self.assertGreaterEqual(sets[c], 18, f"camera {c}: {sets[c]} sets recorded")
            for t in (f"/{c}/hd/camera_info", f"/{c}/sd/image_depth_rect", f"/{c}/sd/camera_info"):
                self.assertEqual(info[t].message_count, sets[c], t)
            # The IR amplitude beside the sets' depth (simulate_bag --hd-mono sends it), on the
            # depth's stamp: all but the few a topic can lose at the edges, as the sets above
            # may lose 5 of 23 (in a full test run cam3 lost its first 2 IR images of 21 sets
            # while the player's connections came up).
            ir = f"/{c}/sd/image_ir_rect"
            self.assertIn(ir, info, f"camera {c}: no IR amplitude recorded")
            self.assertLessEqual(info[ir].message_count, sets[c], ir)
            self.assertGreaterEqual(info[ir].message_count, sets[c] - 5, ir)
        with rosbag.Bag(self.recorded) as bag:
            depth_stamps = {(t, m.header.stamp) for t, m, _ in bag.read_messages(
                topics=[f"/{c}/sd/image_depth_rect" for c in CAMERAS])}
            for t, m, _ in bag.read_messages(topics=[f"/{c}/sd/image_ir_rect" for c in CAMERAS]):
                self.assertIn((t.replace("image_ir_rect", "image_depth_rect"), m.header.stamp),
                              depth_stamps, f"{t}: an IR image without its depth")

    def calibrate(self):
        t0 = time.monotonic()
        report = os.path.join(self.tmp, "report.yaml")
        run = subprocess.run([tool("calibrate_rig"), "--bag", self.recorded, "--config",
                              f"{share()}/config/calibration/thesis_lab.yaml", "--min-placements",
                              "3", "--true-rig", self.true_rig, "--out", self.rig, "--report", report,
                              "--save-observations", os.path.join(self.tmp, "observations.yaml")],
                             capture_output=True, text=True)
        print(run.stderr + run.stdout, flush=True)
        print(f"calibrate_rig: {time.monotonic() - t0:.1f} s", flush=True)
        self.assertEqual(run.returncode, 0, f"calibrate_rig failed (seed {SEED})")
        placements = re.search(r"(\d+) still placements", run.stderr)
        self.assertIsNotNone(placements)
        self.assertEqual(int(placements.group(1)), 6, "placements found (seed 73)")
        with open(report) as f:
            r = yaml.safe_load(f)
        for c in r["cameras"]:
            # 5-6 measured: a corner lost in one frame costs a placement, and so can a set the
            # recorder lost on a loaded machine (23 played; a clean-clone check beside a fuzz
            # run kept 21 of cam4's, which then had 4 placements, still within 2.2 mm of the
            # truth).
            lost = 23 - self.sets[c["name"]]
            self.assertGreaterEqual(c["placements"], max(3, 5 - lost),
                                    f"camera {c['name']} (seed {SEED}, {lost} sets lost)")
            self.assertLess(c["translation_error"], POSITION_LIMIT, f"camera {c['name']} (seed {SEED})")
        self.assertLess(r["anchor_translation"], ANCHOR_LIMIT, f"anchoring (seed {SEED})")

    def replay(self):
        t0 = time.monotonic()
        tv = os.path.join(self.tmp, "tv.bag")
        subprocess.run([tool("simulate_bag"), "--scene", f"{share()}/config/scenes/thesis_vertical.yaml",
                        "--duration", "2.5", "--seed", str(SEED), "--crop", "--quiet", "--out", tv],
                       check=True)
        ends = []
        sub = rospy.Subscriber("/drill_pipe_pose/pipe_ends", PipeEnds, ends.append)
        launch = subprocess.run(["roslaunch", PKG, "replay.launch", f"bag:={tv}", f"rig:={self.rig}"],
                                timeout=120)
        sub.unregister()
        valid = sum(1 for m in ends for e in m.ends if e.valid)
        print(f"replay: {time.monotonic() - t0:.1f} s, {len(ends)} cycles, {valid} valid ends "
              f"(roslaunch rc {launch.returncode})", flush=True)
        self.assertGreater(valid, 0, f"no valid pose published with the calibrated rig (seed {SEED})")


if __name__ == "__main__":
    rostest.rosrun(PKG, "test_calibration_bag", CalibrationBag, sys.argv)
