#!/usr/bin/env python3
"""Every program in src/tools has the same command-line contract (src/tools/cli.hpp):

- `--help` exits 0 and prints the usage, listing every option with a description (the options
  that scripts/, launch/ and test/ pass are checked by name);
- an unknown option exits 2 with a message naming it;
- a bad value exits 2 with a message naming the option.

Run by ctest (CMakeLists.txt): test_tools_cli.py --bin-dir DEVEL/lib/drill_pipe_pose --xml OUT.xml
The programs are only asked to parse their command line, except render_board, which renders two
small frames (test_render_board_writes_frames), and detect_bag, which runs on a tiny colour bag of
simulate_bag (test_detect_bag_on_a_colour_bag), and simulate_calibration with calibrate_rig on
one close camera (test_calibrate_rig_learns_a_cameras_weak_return_bias).
"""
import argparse
import os
import re
import subprocess
import sys
import tempfile
import unittest

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from junit_result import run_suite  # noqa: E402

BIN_DIR = None
REPO = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))

# Every option of each tool, as before the move to CLI11 (names must never change silently).
OPTIONS = {
    "calibrate_rig": ["--observations", "--bag", "--config", "--image-topic", "--save-observations",
                      "--out", "--depth-scale", "--intrinsics", "--no-depth", "--plain",
                      "--min-placements", "--true-rig", "--report", "--no-weak-return-model",
                      "--amplitude-topic", "--no-weak-return-fit"],
    "bench_estimator": ["--method", "--max-cycles", "--work-zone", "--csv", "--label",
                        "--skip-camera", "--no-temporal", "--no-tracking", "--threads",
                        "--vote-fraction", "--box-reach", "--confirmations",
                        "--no-silhouette-points", "--incidence-noise", "--poses-bag"],
    "detect_bag": ["--out", "--crop", "--model", "--config", "--param", "--camera", "--quiet"],
    "detect_target": ["--target", "--squares", "--square", "--marker", "--dictionary"],
    "detector_eval": ["--model", "--darknet-cfg", "--data", "--split", "--input", "--roi", "--conf",
                      "--max-per-class", "--cross-class-nms", "--labels", "--threads", "--timing",
                      "--image", "--repeat", "--csv", "--min-ap"],
    "evaluate": ["--ns", "--csv", "--rate", "--expected"],
    "label_from_poses": ["--recording", "--out", "--poses", "--poses-topic", "--corrections",
                         "--rejected", "--name", "--cameras", "--split", "--format", "--pipe-type",
                         "--max-position-sigma", "--max-axis-sigma", "--min-pose-cameras",
                         "--min-agreeing-cameras", "--min-end-share", "--review-doubt",
                         "--score-against", "--quiet"],
    "make_models": ["--spacing", "--threads"],
    "mesh_to_cloud": ["--spacing", "--scale", "--seed"],
    "render_board": ["--poses", "--out", "--profile", "--off", "--seed", "--repeat", "--fx", "--fy",
                     "--cx", "--cy", "--width", "--height", "--cols", "--rows", "--square",
                     "--margin", "--dark-parity", "--bright-reflectivity", "--dark-reflectivity",
                     "--background-distance", "--depth-offset", "--sensor-param",
                     "--margin-reflectivity-ratio", "--edges-before-refit"],
    "render_dataset": ["--out", "--rig", "--sensors", "--scene", "--cameras", "--random",
                       "--frames", "--augment", "--jpeg-quality", "--seed", "--profile", "--split",
                       "--format", "--negatives", "--drill-floor", "--print-roi", "--quiet"],
    "rig_info": ["--target", "--zone"],
    "simulate_bag": ["--scene", "--out", "--rig", "--duration", "--start", "--profile", "--seed",
                     "--no-detection", "--color", "--crop", "--sensors", "--quiet", "--effect-off",
                     "--hd-mono", "--fps", "--detector-model", "--detector-param", "--true-boxes",
                     "--sensor-param"],
    "simulate_calibration": ["--rig", "--scene", "--profile", "--seed", "--out", "--true-rig",
                             "--frames-per-placement", "--sensors", "--no-weak-return-model",
                             "--sensor-param"],
}


def run(tool, *args):
    return subprocess.run([os.path.join(BIN_DIR, tool)] + list(args), capture_output=True,
                          text=True, timeout=60)


class ToolsCli(unittest.TestCase):
    @classmethod
    def setUpClass(cls):
        cls.tmp = tempfile.mkdtemp(prefix="dpp_cli_")
        cls.file = os.path.join(cls.tmp, "existing.txt")  # passes "existing file" checks
        with open(cls.file, "w") as f:
            f.write("x\n")

    def test_every_tool_is_covered(self):
        tools = sorted(f[:-4] for f in os.listdir(os.path.join(os.path.dirname(__file__), "..",
                                                               "src", "tools"))
                       if f.endswith(".cpp"))
        self.assertEqual(tools, sorted(OPTIONS))

    def test_help(self):
        for tool, options in OPTIONS.items():
            with self.subTest(tool=tool):
                r = run(tool, "--help")
                self.assertEqual(r.returncode, 0, r.stdout + r.stderr)
                self.assertIn("Usage", r.stdout)
                lines = r.stdout.splitlines()
                for opt in options:
                    # The option's line, and a description after it (same or next line).
                    idx = [i for i, l in enumerate(lines) if l.lstrip().startswith(opt + " ")
                           or l.strip() == opt]
                    self.assertTrue(idx, f"{tool} --help does not list {opt}:\n{r.stdout}")
                    i = idx[0]
                    rest = lines[i].strip()[len(opt):].strip()
                    nxt = lines[i + 1].strip() if i + 1 < len(lines) else ""
                    self.assertTrue(rest or nxt, f"{tool} {opt} has no description")

    def test_unknown_option(self):
        for tool in OPTIONS:
            with self.subTest(tool=tool):
                r = run(tool, "--no-such-option")
                self.assertEqual(r.returncode, 2, r.stdout + r.stderr)
                self.assertIn("--no-such-option", r.stderr)

    def test_bad_value(self):
        f, d = self.file, self.tmp
        cases = {
            "bench_estimator": ("--threads", [f, "--threads", "0"]),
            "calibrate_rig": ("--min-placements", ["--observations", f, "--min-placements", "0"]),
            "detect_bag": ("--param", [f, "--out", os.path.join(d, "o.bag"), "--param",
                                       "confidence_threshold=0"]),
            "detect_target": ("--square", [f, "--square", "0"]),
            "detector_eval": ("--conf", ["--model", f, "--data", d, "--conf", "2"]),
            "evaluate": ("--rate", [f, "--rate", "abc"]),
            "label_from_poses": ("--max-position-sigma",
                                 ["--recording", f, "--out", d, "--max-position-sigma", "0"]),
            "make_models": ("--spacing", [d, "--spacing", "-1"]),
            "mesh_to_cloud": ("--scale", [f, os.path.join(d, "o.pcd"), "--scale", "0"]),
            "render_board": ("--square", ["--poses", f, "--out", d, "--square", "0"]),
            "render_dataset": ("--frames", ["--out", d, "--frames", "0"]),
            "rig_info": ("--zone", [f, "--zone", "1", "1", "1", "0", "0", "0"]),
            "simulate_bag": ("--duration", ["--scene", f, "--out", os.path.join(d, "o.bag"),
                                            "--duration", "0"]),
            "simulate_calibration": ("--frames-per-placement",
                                     ["--scene", f, "--out", os.path.join(d, "o.yaml"),
                                      "--frames-per-placement", "0"]),
        }
        self.assertEqual(sorted(cases), sorted(OPTIONS))
        for tool, (opt, args) in cases.items():
            with self.subTest(tool=tool):
                r = run(tool, *args)
                self.assertEqual(r.returncode, 2, r.stdout + r.stderr)
                self.assertIn(opt, r.stderr)

    def test_bad_choice_and_missing_value(self):
        f = self.file
        for tool, opt, args in [
            ("bench_estimator", "--method", [f, "--method", "nope"]),
            ("bench_estimator", "--work-zone", [f, "--work-zone", "1", "2", "3"]),
            ("simulate_bag", "--profile", ["--scene", f, "--out", "x.bag", "--profile", "nope"]),
            ("simulate_bag", "--effect-off", ["--scene", f, "--out", "x.bag", "--effect-off", "x"]),
            ("render_dataset", "--format", ["--out", self.tmp, "--format", "png"]),
            ("label_from_poses", "--format", ["--recording", f, "--out", self.tmp, "--format",
                                              "png"]),
            ("detector_eval", "--input", ["--model", f, "--timing", "320x320", "--input", "4x"]),
            ("detector_eval", "--roi", ["--model", f, "--timing", "320x320", "--roi", "1,2,3"]),
            ("mesh_to_cloud", "--seed", [f, "o.pcd", "--seed", "-3"]),
            ("detect_bag", "--param", [f, "--out", "o.bag", "--param", "no_such_key=1"]),
            ("simulate_bag", "--detector-param", ["--scene", f, "--out", "x.bag",
                                                  "--detector-model", f, "--detector-param",
                                                  "nms_threshold=x"]),
            ("rig_info", "--target", [f, "--target", "1", "2"]),
            ("detect_target", "--target", [f, "--target", "circles"]),
            ("detect_target", "--squares", [f, "--squares", "5by7"]),
            ("render_board", "--off", ["--poses", f, "--out", self.tmp, "--off", "nope"]),
            ("render_board", "--sensor-param", ["--poses", f, "--out", self.tmp, "--sensor-param",
                                                "flying_probability=2"]),
            ("simulate_bag", "--sensor-param", ["--scene", f, "--out", "x.bag", "--sensor-param",
                                                "no_such_parameter=1"]),
            ("render_board", "--dark-parity", ["--poses", f, "--out", self.tmp, "--dark-parity",
                                               "2"]),
        ]:
            with self.subTest(tool=tool, opt=opt):
                r = run(tool, *args)
                self.assertEqual(r.returncode, 2, r.stdout + r.stderr)
                self.assertIn(opt, r.stderr)

    def test_render_dataset_drill_floor_adds_stumps(self):
        """--drill-floor 1: every random scenario also holds a stump (a box end in slips), drawn
        from its own generator: the same scenarios (seed 170) with more box ends in view, and
        some images with two or more."""
        def render(fraction):
            out = os.path.join(self.tmp, "floor%s" % fraction)
            r = run("render_dataset", "--out", out, "--random", "3", "--frames", "1", "--seed",
                    "170", "--cameras", "cam1,cam4", "--format", "yolo", "--negatives", "1",
                    "--drill-floor", fraction, "--quiet")
            self.assertEqual(r.returncode, 0, r.stdout + r.stderr)
            m = re.search(r"(\d+) images \((\d+) box_end, (\d+) pin_end boxes\)", r.stdout)
            self.assertIsNotNone(m, r.stdout)
            most = 0
            labels = os.path.join(out, "yolo", "labels", "train")
            for name in os.listdir(labels):
                with open(os.path.join(labels, name)) as f:
                    most = max(most, sum(1 for line in f if line.split()[:1] == ["0"]))
            return [int(v) for v in m.groups()], most
        (n0, box0, pin0), most0 = render("0")
        (n1, box1, pin1), most1 = render("1")
        self.assertEqual(n0, n1, "the same images (negatives all kept)")
        self.assertGreater(box1, box0, "the stumps' box ends")
        self.assertGreaterEqual(pin1, pin0, "hanging pin ends added, none removed")
        self.assertGreaterEqual(most1, max(2, most0), "a stump and the random box end in one image")
        r = run("render_dataset", "--out", self.tmp, "--drill-floor", "1.5")
        self.assertEqual(r.returncode, 2, r.stdout + r.stderr)
        self.assertIn("--drill-floor", r.stderr)

    def test_render_board_writes_frames(self):
        """The one tool run for real: 2 board poses, ideal sensor, read back without OpenCV."""
        poses = os.path.join(self.tmp, "poses.csv")
        with open(poses, "w") as f:
            f.write("frame,rx,ry,rz,tx,ty,tz\n0001,0,0,0,-0.06,-0.09,1.0\n"
                    "0002,0.3,0,0,-0.06,-0.09,1.5\n")
        out = os.path.join(self.tmp, "board")
        r = run("render_board", "--poses", poses, "--out", out, "--profile", "ideal")
        self.assertEqual(r.returncode, 0, r.stdout + r.stderr)
        self.assertIn("2 frames", r.stdout)
        for frame in ("0001", "0002"):
            with open(os.path.join(out, frame + ".pgm"), "rb") as f:
                data = f.read()
            header = b"P5\n512 424\n65535\n"
            self.assertTrue(data.startswith(header), data[:20])
            self.assertEqual(len(data), len(header) + 512 * 424 * 2)
            if frame == "0001":  # board facing the camera at 1 m: its centre pixel reads 1000 mm
                k = len(header) + 2 * (206 * 512 + 261)
                self.assertEqual(int.from_bytes(data[k:k + 2], "big"), 1000)
                self.assertEqual(int.from_bytes(data[len(header):len(header) + 2], "big"), 0)
        with open(os.path.join(out, "corners.csv")) as f:
            lines = f.read().splitlines()
        self.assertEqual(lines[0], "frame,i,u,v")
        self.assertEqual(len(lines), 1 + 2 * 35)
        frame, i, u, v = lines[1].split(",")
        self.assertEqual((frame, i), ("0001", "0"))
        self.assertAlmostEqual(float(u), 260.9 - 365.4 * 0.06, places=4)
        self.assertAlmostEqual(float(v), 205.6 - 365.4 * 0.09, places=4)
        # A bad poses file: exit 1, naming the file and the line.
        with open(poses, "w") as f:
            f.write("frame,rx,ry,rz,tx,ty,tz\n0001,0,0,0,0,0\n")
        r = run("render_board", "--poses", poses, "--out", out)
        self.assertEqual(r.returncode, 1, r.stdout + r.stderr)
        self.assertIn("poses.csv:2", r.stderr)

    def test_calibrate_rig_learns_a_cameras_weak_return_bias(self):
        """simulate_calibration of one camera 2-3 m from the board (config/rigs/close_single.yaml,
        seed 420) whose sensor reads weak returns with 1.5x the fitted B: calibrate_rig learns
        that B from the board's two prints, writes it to the rig file, and the depth offset that
        goes with it lands within 2 mm of the true one (the solve's own offset, whose light
        print was corrected with the sensor's B, is about 10 mm off)."""
        obs = os.path.join(self.tmp, "close.yaml")
        true_rig = os.path.join(self.tmp, "close_true.yaml")
        rig = os.path.join(self.tmp, "close_rig.yaml")
        r = run("simulate_calibration", "--rig", os.path.join(REPO, "config/rigs/close_single.yaml"),
                "--scene", os.path.join(REPO, "config/scenes/calibration.yaml"), "--seed", "420",
                "--sensor-param", "brightness_bias_coeff=6.05e-9", "--out", obs,
                "--true-rig", true_rig)
        self.assertEqual(r.returncode, 0, r.stdout + r.stderr)
        r = run("calibrate_rig", "--observations", obs, "--true-rig", true_rig, "--out", rig)
        self.assertEqual(r.returncode, 0, r.stdout + r.stderr)
        with open(rig) as f:
            text = f.read()
        b = [float(line.split(":")[1]) for line in text.splitlines() if "weak_return_bias" in line]
        self.assertEqual(len(b), 1, text)
        self.assertAlmostEqual(b[0], 6.05e-9, delta=0.1 * 6.05e-9, msg=r.stdout)
        offset_error = [line for line in r.stdout.splitlines() if line.startswith("max: position")]
        self.assertEqual(len(offset_error), 1, r.stdout)
        mm = float(offset_error[0].split("depth offset ")[1].split(" mm")[0])
        self.assertLess(mm, 2.0, r.stdout)

    def test_detect_bag_on_a_colour_bag(self):
        """detect_bag on 0.1 s of six cameras (simulate_bag --color --no-detection, seed 7):
        one SensorFrame per colour frame, on <cam>/sensor_frame, stamped with the colour capture
        time, with boxes and cropped depth; TF and ground truth copied; the same frames as
        simulate_bag --detector-model in one pass. A bag without a camera's depth info: exit 1,
        naming the camera and the topic."""
        import rosbag  # noqa: E402 (ROS Python, only this test needs it)
        src = os.path.join(os.path.dirname(os.path.abspath(__file__)), "..")
        scene = os.path.join(src, "config", "scenes", "thesis_vertical.yaml")
        model = os.path.join(src, "models", "detector", "pipe_yolo.onnx")
        colour = os.path.join(self.tmp, "colour.bag")
        r = run("simulate_bag", "--scene", scene, "--out", colour, "--duration", "0.1",
                "--seed", "7", "--color", "--no-detection", "--quiet")
        self.assertEqual(r.returncode, 0, r.stdout + r.stderr)
        out = os.path.join(self.tmp, "detected.bag")
        r = run("detect_bag", colour, "--out", out, "--crop", "--model", model, "--quiet")
        self.assertEqual(r.returncode, 0, r.stdout + r.stderr)
        self.assertIn("wrote", r.stdout)

        def frames(path):
            got = {}
            with rosbag.Bag(path) as b:
                for topic, msg, _ in b.read_messages():
                    if topic.endswith("/sensor_frame"):
                        got[(topic, msg.header.stamp.to_nsec())] = msg
            return got

        with rosbag.Bag(colour) as b:
            stamps = {(t, m.header.stamp.to_nsec()) for t, m, _ in
                      b.read_messages() if t.endswith("/qhd/image_color_rect")}
        got = frames(out)
        want = {(t.replace("/qhd/image_color_rect", "/sensor_frame"), s) for t, s in stamps}
        # ApproximateTime may hold back each camera's last set at the bag's end.
        self.assertTrue(set(got) <= want, sorted(set(got) - want))
        self.assertGreaterEqual(len(got), len(want) - 6)
        self.assertGreater(sum(len(m.boxes) for m in got.values()), len(got) // 2)
        for (topic, _), m in got.items():
            self.assertEqual(topic, "/" + m.camera + "/sensor_frame")
            if m.boxes:
                self.assertLess(m.depth.width * m.depth.height, 512 * 424)  # cropped
        with rosbag.Bag(out) as b:
            topics = set(b.get_type_and_topic_info().topics)
        self.assertIn("/tf_static", topics)
        self.assertTrue(any(t.startswith("/ground_truth/") for t in topics), topics)
        self.assertFalse(any("/qhd/" in t or "/sd/" in t for t in topics), topics)

        one_pass = os.path.join(self.tmp, "one_pass.bag")
        r = run("simulate_bag", "--scene", scene, "--out", one_pass, "--duration", "0.1",
                "--seed", "7", "--crop", "--detector-model", model, "--quiet")
        self.assertEqual(r.returncode, 0, r.stdout + r.stderr)
        same = frames(one_pass)
        for key, m in got.items():
            self.assertIn(key, same)
            self.assertEqual([(b.label, b.x_min, b.y_max) for b in m.boxes],
                             [(b.label, b.x_min, b.y_max) for b in same[key].boxes], key)
            self.assertEqual(m.depth.data, same[key].depth.data, key)

        broken = os.path.join(self.tmp, "broken.bag")
        with rosbag.Bag(colour) as b, rosbag.Bag(broken, "w") as w:
            for topic, msg, t in b.read_messages(raw=True):
                if topic != "/cam2/sd/camera_info":
                    w.write(topic, msg, t, raw=True)
        r = run("detect_bag", broken, "--out", os.path.join(self.tmp, "x.bag"), "--quiet")
        self.assertEqual(r.returncode, 1, r.stdout + r.stderr)
        self.assertIn("camera cam2", r.stderr)
        self.assertIn("/cam2/sd/camera_info", r.stderr)
        r = run("detect_bag", colour, "--out", os.path.join(self.tmp, "x.bag"), "--model",
                self.file)
        self.assertEqual(r.returncode, 1, r.stdout + r.stderr)
        self.assertIn(self.file, r.stderr)


def main():
    global BIN_DIR
    p = argparse.ArgumentParser()
    p.add_argument("--bin-dir", required=True)
    p.add_argument("--xml", help="JUnit result file")
    a = p.parse_args()
    BIN_DIR = a.bin_dir
    return run_suite(unittest.defaultTestLoader.loadTestsFromTestCase(ToolsCli), "tools_cli",
                     a.xml)


if __name__ == "__main__":
    sys.exit(main())
