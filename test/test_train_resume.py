#!/usr/bin/env python3
"""Guards scripts/train_detector.py's checkpoints: an interrupted and resumed run ends exactly where
an uninterrupted one does.

    /usr/bin/python3 test/test_train_resume.py        (plain unittest; torch, numpy, cv2)

The data is written here: 8 training and 2 validation images of 128x128 px, grey noise with two
bright rectangles each, labelled box_end and pin_end (seed 22, docs/seeds.md). The runs use the
lite network, 64 px crops, batches of 2 (4 steps an epoch), one thread and a 10-step schedule
(--schedule-steps: the cosine runs over steps, not minutes, so two runs can agree):
  - A: 10 steps in one go;
  - B: stopped after 5 steps (--stop-after-steps, in the middle of epoch 1), then resumed.
On one thread the same operations run in the same order, so A's and B's final weights, batch-norm
statistics and optimiser state must be bitwise equal: a lost random-generator state, optimiser
state or data-order position changes them by far more. A third run, of the full network, is
stopped by SIGTERM; resuming it with --lite must be refused with a message naming --lite, and
resuming it for one more step must carry on its clock (minutes budget). About 15 s on one core.
"""
import os
import shutil
import signal
import subprocess
import sys
import tempfile
import time
import unittest

import cv2
import numpy as np
import torch

HERE = os.path.dirname(os.path.abspath(__file__))
TRAIN = os.path.join(os.path.dirname(HERE), "scripts", "train_detector.py")
SEED = 22
# The run: 10 steps of 2 crops (2.5 epochs of the 8 images), so that the stop at step 5 falls in
# the middle of an epoch and the run validates once (epoch 2, when the budget ends).
RUN = ["--lite", "--threads", "1", "--seed", str(SEED), "--schedule-steps", "10", "--batch", "2",
       "--crop", "64", "--export-size", "64x64"]
STOP_AT = 5


def write_dataset(root):
    """A YOLO dataset (images/<split>, labels/<split>) of bright rectangles on grey noise."""
    r = np.random.RandomState(SEED)
    for split, n in (("train", 8), ("val", 2)):
        os.makedirs(os.path.join(root, "images", split))
        os.makedirs(os.path.join(root, "labels", split))
        for i in range(n):
            img = r.randint(40, 90, (128, 128, 3)).astype(np.uint8)
            rows = []
            for cls, colour in ((0, (220, 220, 220)), (1, (60, 200, 240))):
                w, h = r.randint(12, 40, 2)
                x0, y0 = r.randint(0, 128 - w), r.randint(0, 128 - h)
                img[y0:y0 + h, x0:x0 + w] = colour
                rows.append("%d %.6f %.6f %.6f %.6f" % (cls, (x0 + w / 2) / 128, (y0 + h / 2) / 128,
                                                        w / 128, h / 128))
            cv2.imwrite(os.path.join(root, "images", split, "%03d.png" % i), img)
            with open(os.path.join(root, "labels", split, "%03d.txt" % i), "w") as f:
                f.write("\n".join(rows) + "\n")


def train(*args):
    return subprocess.run([sys.executable, TRAIN] + list(args), capture_output=True, text=True,
                          timeout=300)


def load(path):
    return torch.load(path, map_location="cpu")


def max_diff(a, b):
    """Largest absolute difference between two nested structures of tensors and numbers."""
    if isinstance(a, dict):
        assert set(a) == set(b), (sorted(a), sorted(b))
        return max([max_diff(a[k], b[k]) for k in a] + [0.0])
    if isinstance(a, (list, tuple)):
        assert len(a) == len(b)
        return max([max_diff(x, y) for x, y in zip(a, b)] + [0.0])
    if torch.is_tensor(a):
        return float((a.double() - b.double()).abs().max()) if a.numel() else 0.0
    return abs(float(a) - float(b))


class TrainResume(unittest.TestCase):
    @classmethod
    def setUpClass(cls):
        cls.tmp = tempfile.mkdtemp(prefix="test_train_resume_")
        cls.data = os.path.join(cls.tmp, "data")
        write_dataset(cls.data)
        data = ["--data", cls.data, "--val", cls.data]
        cls.a_dir, cls.b_dir = os.path.join(cls.tmp, "a"), os.path.join(cls.tmp, "b")
        cls.a = train(*(data + RUN + ["--out", cls.a_dir]))
        cls.b_stop = train(*(data + RUN + ["--out", cls.b_dir, "--stop-after-steps", str(STOP_AT)]))
        cls.b_mid = load(os.path.join(cls.b_dir, "pipe_yolo.ckpt")) if cls.b_stop.returncode == 0 \
            else None
        # Resumed with only what is not in the checkpoint: the rest comes from it.
        cls.b = train("--data", cls.data, "--val", cls.data, "--threads", "1", "--export-size",
                      "64x64", "--out", cls.b_dir, "--resume",
                      os.path.join(cls.b_dir, "pipe_yolo.ckpt"))

    @classmethod
    def tearDownClass(cls):
        shutil.rmtree(cls.tmp, ignore_errors=True)

    def ckpt(self, folder):
        return load(os.path.join(folder, "pipe_yolo.ckpt"))

    def test_runs_succeed(self):
        for name, p in (("A", self.a), ("B stop", self.b_stop), ("B resume", self.b)):
            self.assertEqual(p.returncode, 0, "%s: %s%s" % (name, p.stdout, p.stderr))
        self.assertIn("stopped (--stop-after-steps 5) at epoch 1 step 5", self.b_stop.stdout)
        self.assertIn("resumed from epoch 1 step 5, 5 of 10 scheduled steps done", self.b.stdout)
        for folder in (self.a_dir, self.b_dir):
            self.assertTrue(os.path.isfile(os.path.join(folder, "pipe_yolo.onnx")))
            self.assertEqual([f for f in os.listdir(folder) if f.endswith(".tmp")], [])

    def test_resumed_run_equals_uninterrupted(self):
        a, b = self.ckpt(self.a_dir), self.ckpt(self.b_dir)
        self.assertEqual((a["step"], b["step"]), (10, 10))
        self.assertEqual(max_diff(a["model"], b["model"]), 0.0, "weights and batch-norm statistics")
        self.assertEqual(max_diff(a["optimizer"]["state"], b["optimizer"]["state"]), 0.0,
                         "optimiser state")
        self.assertEqual(a["rng"]["data_order"], b["rng"]["data_order"])
        self.assertEqual(a["best_val_ap"], b["best_val_ap"])

    def test_checkpoint_fields(self):
        mid = self.b_mid
        self.assertIsNotNone(mid, self.b_stop.stderr)
        for field in ("model", "optimizer", "epoch", "step", "spent_s", "args", "rng",
                      "best_val_ap", "order", "epoch_step", "finished"):
            self.assertIn(field, mid)
        self.assertEqual((mid["epoch"], mid["epoch_step"], mid["step"]), (1, 1, STOP_AT))
        self.assertEqual(sorted(mid["order"]), list(range(8)))
        self.assertFalse(mid["finished"])
        self.assertGreater(mid["spent_s"], 0.0)
        self.assertIsNone(mid["best_val_ap"])  # no validation yet (epochs 2, 5, ... and the end)
        self.assertEqual(set(mid["rng"]), {"python", "numpy", "torch", "data_order"})
        for field, value in (("lite", True), ("width", 0.5), ("crop", 64), ("batch", 2),
                             ("seed", SEED), ("schedule_steps", 10), ("minutes", None),
                             ("lr", 2e-3)):
            self.assertEqual(mid["args"][field], value, field)
        end = self.ckpt(self.a_dir)
        self.assertTrue(end["finished"])
        self.assertIsInstance(end["best_val_ap"], float)
        self.assertEqual(end["best_val_epoch"], 2)

    def test_plain_state_dict_loads_weights_only(self):
        out = os.path.join(self.tmp, "plain")
        p = train("--data", self.data, "--lite", "--threads", "1", "--schedule-steps", "1",
                  "--batch", "2", "--crop", "64", "--export-size", "64x64", "--out", out,
                  "--resume", os.path.join(self.a_dir, "pipe_yolo.pt"))
        self.assertEqual(p.returncode, 0, p.stdout + p.stderr)
        self.assertIn("holds weights only (a state_dict): the optimiser state and the schedule "
                      "restart", p.stdout)

    def test_sigterm_saves_then_lite_is_refused(self):
        out = os.path.join(self.tmp, "full")
        proc = subprocess.Popen([sys.executable, TRAIN, "--data", self.data, "--threads", "1",
                                 "--seed", str(SEED), "--minutes", "10", "--batch", "2",
                                 "--crop", "64", "--out", out],
                                stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True)
        lines = []
        for line in proc.stdout:  # the handlers are in place once this line is out
            lines.append(line)
            if line.startswith("checkpoint "):
                # 1.5 s of training first: far longer than the one step resumed below (~0.1 s),
                # so a resumed clock that restarted at 0 would show.
                time.sleep(1.5)
                proc.send_signal(signal.SIGTERM)
                break
        rest, _ = proc.communicate(timeout=120)
        log = "".join(lines) + rest
        self.assertEqual(proc.returncode, 128 + signal.SIGTERM, log)
        self.assertIn("stopped (SIGTERM) at epoch", log)
        ckpt = os.path.join(out, "pipe_yolo.ckpt")
        saved = load(ckpt)
        self.assertFalse(saved["args"]["lite"])
        self.assertFalse(saved["finished"])
        self.assertGreater(saved["spent_s"], 1.0)
        # --stop-after-steps: were the option taken, the run would stop at once.
        p = train("--data", self.data, "--threads", "1", "--out", out, "--resume", ckpt, "--lite",
                  "--stop-after-steps", "1")
        self.assertEqual(p.returncode, 1, p.stdout + p.stderr)
        self.assertIn("--lite contradicts the checkpoint's run (no --lite)", p.stderr)
        # Minutes mode: the resumed run starts from the time spent and adds its own.
        p = train("--data", self.data, "--threads", "1", "--out", out, "--resume", ckpt,
                  "--stop-after-steps", str(saved["step"] + 1))
        self.assertEqual(p.returncode, 0, p.stdout + p.stderr)
        self.assertIn("resumed from epoch %d step %d, %.1f of 10.0 min spent" %
                      (saved["epoch"], saved["step"], saved["spent_s"] / 60), p.stdout)
        after = load(ckpt)
        self.assertEqual(after["step"], saved["step"] + 1)
        self.assertGreater(after["spent_s"], saved["spent_s"])


if __name__ == "__main__":
    # ctest (CMakeLists.txt): test_train_resume.py --xml OUT.xml; alone: no arguments.
    sys.path.insert(0, HERE)
    from junit_result import run_suite
    xml = sys.argv[2] if len(sys.argv) == 3 and sys.argv[1] == "--xml" else None
    sys.exit(run_suite(unittest.defaultTestLoader.loadTestsFromModule(sys.modules[__name__]),
                       "train_resume", xml))
