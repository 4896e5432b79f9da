#!/usr/bin/env python3
"""Trains the sensor node's tool-joint detector (box_end, pin_end) from scratch on CPU and exports
it to ONNX for OpenCV's cv::dnn (the pipe_detector node, YoloDetector in core/detector).

The network ("PipeYOLO") is a small anchor-free, single-scale YOLO-style detector defined here:
a stride-32 LeakyReLU/BatchNorm backbone, a feature-pyramid path back to stride 8 (tool joints are
10-60 px in QHD at the rig's 5-8 m), and one head at stride 8 whose output is the "grid" layout
that core/detector/yolo_decoding.hpp decodes:

    [1, 5 + C, H/8, W/8]: sigmoid(tx), sigmoid(ty), tw, th, sigmoid(obj), sigmoid(class)...
    centre = (col + 2 sigmoid(tx) - 0.5) * 8,  size = 8 * exp(tw)   [input px]

Fully convolutional: the exported model runs at any input size that is a multiple of 32.

Data: a YOLO dataset as scripts/../src/tools/render_dataset writes it (images/<split>/*.jpg,
labels/<split>/*.txt with `class cx cy w h` normalised). Training samples are random crops
(--crop px) of randomly scaled images (--scale-min/--scale-max: the letterbox scale of the node's
region of interest), mirrored, with brightness/contrast/colour jitter and blur.

The shipped model (55 minutes on 2 cores, see models/detector/README.md):
    render_dataset --out D/train --random 160 --frames 5 --seed 1 --split train --format yolo \\
        --negatives 0.1
    render_dataset --out D/val --random 16 --frames 5 --seed 2 --split val --format yolo
    /usr/bin/python3 scripts/train_detector.py --lite --data D/train/yolo --val D/val/yolo \\
        --val-split val --out D/lite --minutes 55 --eval-scale 1.0
scripts/train_detector_full runs these three commands (D is .ws/detector_train by default). It
skips a render that is already there and resumes the training from its checkpoint.
CI (a few minutes at most, checks that the pipeline and the ONNX export still work):
    /usr/bin/python3 scripts/train_detector.py --smoke --lite --data SMOKE/yolo --out SMOKE/model

Fine-tuning on a rig's own data (label_from_poses, README "Teach the detector a new rig"):
    /usr/bin/python3 scripts/train_detector.py --finetune DATA/yolo --out D/ft [--minutes 20]
starts from the shipped model's weights, read from its ONNX file (--init-onnx, default
models/detector/pipe_yolo.onnx, the lite network), with the batch norms frozen (the export folds
them into the convolutions, so each starts as the identity plus the folded bias), a lower learning
rate (--lr default 5e-4) and a 10-minute default budget. Mix in some of the original renders
(--data-extra) to keep what the model knew.

Checkpoints and resume. The run writes OUT/NAME.ckpt (default pipe_yolo.ckpt) at the end of each
epoch, when the budget ends, and on SIGINT or SIGTERM. On a signal it finishes the step, saves
and exits with status 128 + the signal's number; a second signal stops at once. The file is
written to a temporary file and then renamed, so a kill never leaves half a checkpoint. It holds
the model, the optimiser state, the epoch and step (and the image order of an unfinished epoch),
the training time spent, the options that define the network and the schedule, the random
generators' states and the best validation AP. It is a pickle: resume only your own files.
    /usr/bin/python3 scripts/train_detector.py --data D/train/yolo --val D/val/yolo \\
        --val-split val --out D/lite --resume D/lite/pipe_yolo.ckpt
continues where the run stopped: the cosine schedule goes on from the time already spent, and
the budget left is the budget less that time. Options you leave out come from the checkpoint.
An option you give must agree with it (--lite, --width, --lr, --minutes, --schedule-steps,
--epochs, --batch, --crop, --scale-min, --scale-max, --seed, --finetune, --smoke); the run
refuses otherwise and names the option. The training set must hold as many images as before.
--resume X.pt with a plain state_dict (NAME.pt, also written each epoch) loads the weights only:
the optimiser and the schedule start again, and the run prints a warning.
--schedule-steps N sets the budget in steps, and the cosine runs over steps instead of minutes.
With it and --threads 1, a run stopped by --stop-after-steps K and resumed ends with the same
weights, bit for bit, as one run (test/test_train_resume.py).
"""

import argparse
import inspect
import math
import os
import random
import signal
import sys
import time

import numpy as np

try:
    import cv2
except ImportError:  # pragma: no cover
    sys.exit("train_detector: python3-opencv is required (apt-get install python3-opencv)")
try:
    import torch
    import torch.nn as nn
    import torch.nn.functional as F
except ImportError:  # pragma: no cover
    sys.exit("train_detector: python3-torch is required (apt-get install python3-torch)")

CLASSES = ["box_end", "pin_end"]
STRIDE = 8
OPSET = 11  # OpenCV 4.6's ONNX importer reads opset 11 Resize/Concat/LeakyRelu reliably


# --------------------------------------------------------------------------------------------
# Network
def conv(c_in, c_out, k=3, s=1):
    return nn.Sequential(nn.Conv2d(c_in, c_out, k, s, k // 2, bias=False), nn.BatchNorm2d(c_out),
                         nn.LeakyReLU(0.1, inplace=True))


class Residual(nn.Module):
    def __init__(self, c):
        super().__init__()
        self.a = conv(c, c // 2, 1)
        self.b = conv(c // 2, c, 3)

    def forward(self, x):
        return x + self.b(self.a(x))


class PipeYOLO(nn.Module):
    """Anchor-free single-scale (stride 8) detector: ~0.63 M parameters at width 1.0 (the
    full network), ~0.15 M for the "lite" one (width 0.5, no stride-4 residual, one 3x3 conv at
    stride 8), which runs about 3x faster at the colour image's native size."""

    def __init__(self, num_classes=2, width=1.0, s4_residual=True, p8_convs=2):
        super().__init__()
        c = [max(8, int(round(v * width))) for v in (16, 32, 64, 96, 128)]
        self.s2 = conv(3, c[0], 3, 2)
        self.s4 = (nn.Sequential(conv(c[0], c[1], 3, 2), Residual(c[1])) if s4_residual
                   else conv(c[0], c[1], 3, 2))
        self.s8 = nn.Sequential(conv(c[1], c[2], 3, 2), Residual(c[2]), Residual(c[2]))
        self.s16 = nn.Sequential(conv(c[2], c[3], 3, 2), Residual(c[3]), Residual(c[3]))
        self.s32 = nn.Sequential(conv(c[3], c[4], 3, 2), Residual(c[4]), conv(c[4], c[4], 1))
        self.up32 = nn.Sequential(conv(c[4], c[3], 1), nn.Upsample(scale_factor=2, mode="nearest"))
        self.p16 = nn.Sequential(conv(2 * c[3], c[3], 1), conv(c[3], c[3], 3))
        self.up16 = nn.Sequential(conv(c[3], c[2], 1), nn.Upsample(scale_factor=2, mode="nearest"))
        self.p8 = nn.Sequential(conv(2 * c[2], c[2], 1),
                                *[conv(c[2], c[2], 3) for _ in range(max(1, p8_convs))])
        self.xy = nn.Conv2d(c[2], 2, 1)
        self.wh = nn.Conv2d(c[2], 2, 1)
        self.obj = nn.Conv2d(c[2], 1, 1)
        self.cls = nn.Conv2d(c[2], num_classes, 1)
        # Priors: objects are rare (obj ~ 0.01), sizes ~ 3 cells.
        nn.init.constant_(self.obj.bias, -4.5)
        nn.init.constant_(self.wh.bias, 1.0)
        nn.init.constant_(self.cls.bias, -1.0)

    def features(self, x):
        x8 = self.s8(self.s4(self.s2(x)))
        x16 = self.s16(x8)
        x32 = self.s32(x16)
        p16 = self.p16(torch.cat([self.up32(x32), x16], 1))
        return self.p8(torch.cat([self.up16(p16), x8], 1))

    def forward_raw(self, x):
        f = self.features(x)
        return self.xy(f), self.wh(f), self.obj(f), self.cls(f)

    def forward(self, x):
        """The exported "grid" output: [B, 5 + C, H/8, W/8]."""
        xy, wh, obj, cls = self.forward_raw(x)
        return torch.cat([torch.sigmoid(xy), wh, torch.sigmoid(obj), torch.sigmoid(cls)], 1)


# --------------------------------------------------------------------------------------------
# Data
def read_split(root, split):
    """(image path, labels array [n, 5] = class, x0, y0, x1, y1 in pixels) for a YOLO split."""
    img_dir = os.path.join(root, "images", split)
    lab_dir = os.path.join(root, "labels", split)
    if not os.path.isdir(img_dir):
        sys.exit("train_detector: no image folder %s (expected a YOLO dataset: images/%s, "
                 "labels/%s)" % (img_dir, split, split))
    items = []
    for name in sorted(os.listdir(img_dir)):
        stem, ext = os.path.splitext(name)
        if ext.lower() not in (".jpg", ".jpeg", ".png"):
            continue
        path = os.path.join(img_dir, name)
        rows = []
        lp = os.path.join(lab_dir, stem + ".txt")
        if os.path.exists(lp):
            for line in open(lp):
                v = line.split()
                if len(v) == 5:
                    rows.append([float(x) for x in v])
        items.append((path, np.array(rows, dtype=np.float32).reshape(-1, 5)))
    if not items:
        sys.exit("train_detector: %s holds no images" % img_dir)
    return items


class Samples:
    """Images kept JPEG-compressed in memory; random scaled crops on demand."""

    def __init__(self, items, crop, scale_min, scale_max, augment=True):
        self.crop, self.smin, self.smax, self.augment = crop, scale_min, scale_max, augment
        self.data = []
        for path, lab in items:
            with open(path, "rb") as f:
                buf = np.frombuffer(f.read(), np.uint8)
            self.data.append((buf, lab))

    def __len__(self):
        return len(self.data)

    def image(self, i):
        buf, lab = self.data[i]
        img = cv2.imdecode(buf, cv2.IMREAD_COLOR)
        h, w = img.shape[:2]
        boxes = np.zeros((len(lab), 5), np.float32)
        if len(lab):
            boxes[:, 0] = lab[:, 0]
            boxes[:, 1] = (lab[:, 1] - lab[:, 3] / 2) * w
            boxes[:, 2] = (lab[:, 2] - lab[:, 4] / 2) * h
            boxes[:, 3] = (lab[:, 1] + lab[:, 3] / 2) * w
            boxes[:, 4] = (lab[:, 2] + lab[:, 4] / 2) * h
        return img, boxes

    def sample(self, i, rng):
        img, boxes = self.image(i)
        s = math.exp(rng.uniform(math.log(self.smin), math.log(self.smax)))
        img = cv2.resize(img, None, fx=s, fy=s,
                         interpolation=cv2.INTER_AREA if s < 1 else cv2.INTER_LINEAR)
        boxes[:, 1:] *= s
        h, w = img.shape[:2]
        c = self.crop
        # Centre the crop near an object most of the time.
        if len(boxes) and rng.random() < 0.85:
            b = boxes[rng.randrange(len(boxes))]
            cx = (b[1] + b[3]) / 2 + rng.uniform(-0.4, 0.4) * c
            cy = (b[2] + b[4]) / 2 + rng.uniform(-0.4, 0.4) * c
        else:
            cx, cy = rng.uniform(0, w), rng.uniform(0, h)
        x0 = int(round(cx - c / 2))
        y0 = int(round(cy - c / 2))
        out = np.full((c, c, 3), 114, np.uint8)
        sx0, sy0 = max(x0, 0), max(y0, 0)
        sx1, sy1 = min(x0 + c, w), min(y0 + c, h)
        if sx1 > sx0 and sy1 > sy0:
            out[sy0 - y0:sy1 - y0, sx0 - x0:sx1 - x0] = img[sy0:sy1, sx0:sx1]
        boxes[:, [1, 3]] -= x0
        boxes[:, [2, 4]] -= y0
        # Keep boxes with >= 50 % of their area inside the crop (clipped); ignore-free.
        if len(boxes):
            area = (boxes[:, 3] - boxes[:, 1]) * (boxes[:, 4] - boxes[:, 2])
            cl = boxes.copy()
            cl[:, [1, 3]] = cl[:, [1, 3]].clip(0, c)
            cl[:, [2, 4]] = cl[:, [2, 4]].clip(0, c)
            carea = (cl[:, 3] - cl[:, 1]).clip(0) * (cl[:, 4] - cl[:, 2]).clip(0)
            boxes = cl[(carea >= 0.5 * area) & (carea > 4)]
        if self.augment:
            if rng.random() < 0.5:  # mirror
                out = out[:, ::-1].copy()
                x0b = c - boxes[:, 3]
                boxes[:, 3] = c - boxes[:, 1]
                boxes[:, 1] = x0b
            f = out.astype(np.float32)
            f = f * rng.uniform(0.65, 1.35) + rng.uniform(-30, 30)  # contrast, brightness
            f *= np.array([rng.uniform(0.85, 1.15) for _ in range(3)], np.float32)  # white bal.
            if rng.random() < 0.3:
                f = cv2.GaussianBlur(f, (3, 3), rng.uniform(0.3, 1.0))
            if rng.random() < 0.5:
                f += np.random.normal(0, rng.uniform(1, 6), f.shape).astype(np.float32)
            out = f.clip(0, 255).astype(np.uint8)
        return out, boxes


def to_tensor(imgs):
    """BGR uint8 HWC list -> RGB float NCHW in [0, 1] (as cv::dnn blobFromImage(swapRB))."""
    a = np.stack([im[:, :, ::-1] for im in imgs]).astype(np.float32) / 255.0
    return torch.from_numpy(np.ascontiguousarray(a.transpose(0, 3, 1, 2)))


# --------------------------------------------------------------------------------------------
# Loss
def box_giou(a, b):
    """GIoU of boxes [N, 4] (x0, y0, x1, y1)."""
    iw = (torch.min(a[:, 2], b[:, 2]) - torch.max(a[:, 0], b[:, 0])).clamp(min=0)
    ih = (torch.min(a[:, 3], b[:, 3]) - torch.max(a[:, 1], b[:, 1])).clamp(min=0)
    inter = iw * ih
    area_a = (a[:, 2] - a[:, 0]) * (a[:, 3] - a[:, 1])
    area_b = (b[:, 2] - b[:, 0]) * (b[:, 3] - b[:, 1])
    union = area_a + area_b - inter + 1e-7
    iou = inter / union
    cw = torch.max(a[:, 2], b[:, 2]) - torch.min(a[:, 0], b[:, 0])
    ch = torch.max(a[:, 3], b[:, 3]) - torch.min(a[:, 1], b[:, 1])
    carea = cw * ch + 1e-7
    return iou - (carea - union) / carea, iou


def build_targets(batch_boxes, H, W, nc):
    """Positives: the cell holding each box centre plus its two nearest neighbours (YOLOv5)."""
    bi, gy, gx, tbox, tcls = [], [], [], [], []
    for b, boxes in enumerate(batch_boxes):
        for row in boxes:
            cls, x0, y0, x1, y1 = row
            cx, cy = (x0 + x1) / 2 / STRIDE, (y0 + y1) / 2 / STRIDE
            j, i = int(cx), int(cy)
            fx, fy = cx - j, cy - i
            cells = [(i, j), (i, j + (1 if fx > 0.5 else -1)), (i + (1 if fy > 0.5 else -1), j)]
            for (ci, cj) in cells:
                if 0 <= ci < H and 0 <= cj < W:
                    bi.append(b)
                    gy.append(ci)
                    gx.append(cj)
                    tbox.append([x0, y0, x1, y1])
                    tcls.append(int(cls))
    return (torch.tensor(bi, dtype=torch.long), torch.tensor(gy, dtype=torch.long),
            torch.tensor(gx, dtype=torch.long), torch.tensor(tbox, dtype=torch.float32).reshape(-1, 4),
            torch.tensor(tcls, dtype=torch.long))


def compute_loss(model, imgs, batch_boxes, nc):
    xy, wh, obj, cls = model.forward_raw(imgs)
    B, _, H, W = obj.shape
    bi, gy, gx, tbox, tcls = build_targets(batch_boxes, H, W, nc)
    tobj = torch.zeros_like(obj)
    lbox = torch.zeros(())
    lcls = torch.zeros(())
    if len(bi):
        pxy = torch.sigmoid(xy[bi, :, gy, gx])
        pwh = wh[bi, :, gy, gx].clamp(max=8.0)
        cx = (gx.float() + 2 * pxy[:, 0] - 0.5) * STRIDE
        cy = (gy.float() + 2 * pxy[:, 1] - 0.5) * STRIDE
        w = STRIDE * torch.exp(pwh[:, 0])
        h = STRIDE * torch.exp(pwh[:, 1])
        pbox = torch.stack([cx - w / 2, cy - h / 2, cx + w / 2, cy + h / 2], 1)
        giou, iou = box_giou(pbox, tbox)
        lbox = (1.0 - giou).mean()
        tobj[bi, 0, gy, gx] = iou.detach().clamp(0).float() * 0.5 + 0.5
        t = torch.zeros(len(bi), nc)
        t[torch.arange(len(bi)), tcls] = 1.0
        lcls = F.binary_cross_entropy_with_logits(cls[bi, :, gy, gx], t)
    lobj = F.binary_cross_entropy_with_logits(obj, tobj, reduction="sum") / (B * 64.0)
    return 2.0 * lbox + lobj + 1.0 * lcls, (float(lbox), float(lobj), float(lcls))


# --------------------------------------------------------------------------------------------
# Evaluation (quick, in Python: the authoritative figure comes from the C++ detector_eval tool)
def decode(out, conf=0.01):
    """Grid output [5+C, H, W] (numpy) -> list of (cls, score, x0, y0, x1, y1) in input px."""
    C, H, W = out.shape
    nc = C - 5
    ys, xs = np.nonzero(out[4] >= conf)
    dets = []
    for y, x in zip(ys, xs):
        cx = (x + 2 * out[0, y, x] - 0.5) * STRIDE
        cy = (y + 2 * out[1, y, x] - 0.5) * STRIDE
        w = STRIDE * math.exp(min(out[2, y, x], 8.0))
        h = STRIDE * math.exp(min(out[3, y, x], 8.0))
        for c in range(nc):
            s = out[4, y, x] * out[5 + c, y, x]
            if s >= conf:
                dets.append((c, s, cx - w / 2, cy - h / 2, cx + w / 2, cy + h / 2))
    return dets


def iou_np(a, b):
    iw = max(0.0, min(a[2], b[2]) - max(a[0], b[0]))
    ih = max(0.0, min(a[3], b[3]) - max(a[1], b[1]))
    inter = iw * ih
    u = (a[2] - a[0]) * (a[3] - a[1]) + (b[2] - b[0]) * (b[3] - b[1]) - inter
    return inter / u if u > 0 else 0.0


def nms(dets, thr=0.45):
    dets = sorted(dets, key=lambda d: -d[1])
    keep = []
    for d in dets:
        if all(k[0] != d[0] or iou_np(k[2:], d[2:]) <= thr for k in keep):
            keep.append(d)
    return keep


def average_precision(scores_tp, n_gt):
    """VOC all-point interpolated AP from [(score, is_tp)]."""
    if n_gt == 0:
        return float("nan")
    scores_tp.sort(key=lambda s: -s[0])
    tp = np.cumsum([t for _, t in scores_tp]) if scores_tp else np.zeros(0)
    fp = np.cumsum([1 - t for _, t in scores_tp]) if scores_tp else np.zeros(0)
    rec = tp / n_gt if len(tp) else np.zeros(0)
    prec = tp / np.maximum(tp + fp, 1e-9) if len(tp) else np.zeros(0)
    mrec = np.concatenate([[0.0], rec, [1.0]])
    mpre = np.concatenate([[1.0], prec, [0.0]])
    for i in range(len(mpre) - 2, -1, -1):
        mpre[i] = max(mpre[i], mpre[i + 1])
    idx = np.where(mrec[1:] != mrec[:-1])[0]
    return float(np.sum((mrec[idx + 1] - mrec[idx]) * mpre[idx + 1]))


def evaluate(model, items, scale, nc, limit=None):
    """mAP@0.5 per class on whole images scaled by `scale` and padded to a multiple of 32."""
    model.eval()
    per = [[] for _ in range(nc)]
    ngt = [0] * nc
    with torch.no_grad():
        for path, lab in items[:limit]:
            img = cv2.imread(path)
            h, w = img.shape[:2]
            rw, rh = int(round(w * scale)), int(round(h * scale))
            W, H = (rw + 31) // 32 * 32, (rh + 31) // 32 * 32
            inp = np.full((H, W, 3), 114, np.uint8)
            px, py = (W - rw) // 2, (H - rh) // 2
            inp[py:py + rh, px:px + rw] = cv2.resize(img, (rw, rh), interpolation=cv2.INTER_AREA)
            out = model(to_tensor([inp]))[0].numpy()
            dets = nms(decode(out))
            gts = []
            for c, x, y, bw, bh in lab:
                gts.append((int(c), (x - bw / 2) * w, (y - bh / 2) * h, (x + bw / 2) * w,
                            (y + bh / 2) * h))
                ngt[int(c)] += 1
            used = [False] * len(gts)
            for c, s, x0, y0, x1, y1 in dets:
                box = ((x0 - px) / scale, (y0 - py) / scale, (x1 - px) / scale, (y1 - py) / scale)
                best, bj = 0.5, -1
                for j, g in enumerate(gts):
                    if g[0] == c and not used[j]:
                        o = iou_np(box, g[1:])
                        if o >= best:
                            best, bj = o, j
                if bj >= 0:
                    used[bj] = True
                per[c].append((s, 1 if bj >= 0 else 0))
    model.train()
    return [average_precision(per[c], ngt[c]) for c in range(nc)], ngt


# --------------------------------------------------------------------------------------------
def export_onnx(model, path, size):
    """Writes `path` (through a temporary file, so it exists only once it is whole and checked)."""
    model.eval()
    dummy = torch.zeros(1, 3, size[1], size[0])
    tmp = path + ".tmp"
    torch.onnx.export(model, dummy, tmp, opset_version=OPSET, input_names=["images"],
                      output_names=["output"], do_constant_folding=True)
    model.train()
    # Check that OpenCV's importer reads it and that it runs at another input size too.
    net = cv2.dnn.readNetFromONNX(tmp)
    for w, h in (size, (size[0] + 64, size[1] + 32)):
        net.setInput(np.zeros((1, 3, h, w), np.float32))
        out = net.forward()
        if out.shape != (1, 5 + len(CLASSES), h // STRIDE, w // STRIDE):
            sys.exit("train_detector: OpenCV runs %s at %dx%d with output %s, expected %s" %
                     (path, w, h, out.shape, (1, 5 + len(CLASSES), h // STRIDE, w // STRIDE)))
    os.replace(tmp, path)
    print("exported %s (opset %d, %.2f MB), OpenCV %s reads it" %
          (path, OPSET, os.path.getsize(path) / 1e6, cv2.__version__))


# --------------------------------------------------------------------------------------------
# Fine-tuning from the shipped ONNX model
def load_onnx_weights(model, path):
    """Loads the weights of an exported PipeYOLO (ONNX, batch norms folded into the convolutions)
    into `model`: each convolution's weights, its folded bias into the following BatchNorm's bias
    (weight 1, running mean 0, running variance 1 - eps: the identity plus the bias). Checks that
    the result computes what OpenCV computes with the ONNX file."""
    net = cv2.dnn.readNetFromONNX(path)
    modules = dict(model.named_modules())
    loaded = 0
    with torch.no_grad():
        for name in net.getLayerNames():
            layer = net.getLayer(name)
            if layer.type != "Convolution":
                continue
            # ONNX scopes: /s8/s8.1/a/a.0/Conv is module s8.1.a.0 (a Sequential's child carries
            # its parent's name as a prefix, an attribute child does not).
            parts = name.split("!")[-1].strip("/").split("/")
            path_parts, last = [], None
            for c in parts[:-1]:
                path_parts.append(c[len(last) + 1:] if last and c.startswith(last + ".") else c)
                last = c
            mod_name = ".".join(path_parts)
            if parts[-1] != "Conv" or mod_name not in modules:
                sys.exit("train_detector: %s: layer %s is not a PipeYOLO convolution (was the model "
                         "exported by this script?)" % (path, name))
            conv_mod = modules[mod_name]
            w = torch.from_numpy(np.ascontiguousarray(layer.blobs[0]))
            b = torch.from_numpy(np.ascontiguousarray(layer.blobs[1]).reshape(-1))
            if tuple(conv_mod.weight.shape) != tuple(w.shape):
                sys.exit("train_detector: %s: %s has weights %s, the network %s (use --lite for "
                         "the shipped model)" % (path, mod_name, tuple(w.shape),
                                                 tuple(conv_mod.weight.shape)))
            conv_mod.weight.copy_(w)
            if conv_mod.bias is not None:
                conv_mod.bias.copy_(b)
            else:
                head, _, idx = mod_name.rpartition(".")
                bn = modules["%s.%d" % (head, int(idx) + 1) if head else str(int(idx) + 1)]
                bn.weight.fill_(1.0)
                bn.bias.copy_(b)
                bn.running_mean.zero_()
                bn.running_var.fill_(1.0 - bn.eps)
            loaded += 1
    n_conv = sum(1 for m in model.modules() if isinstance(m, nn.Conv2d))
    if loaded != n_conv:
        sys.exit("train_detector: %s holds %d convolutions, the network %d" % (path, loaded, n_conv))
    # The same output as OpenCV's on a test input.
    model.eval()
    x = np.random.RandomState(0).rand(1, 3, 64, 96).astype(np.float32)
    net.setInput(x)
    ref = net.forward()
    with torch.no_grad():
        out = model(torch.from_numpy(x)).numpy()
    err = float(np.abs(out - ref).max())
    if err > 1e-3:
        sys.exit("train_detector: the weights read from %s give outputs %.2g off OpenCV's" %
                 (path, err))
    print("loaded %d convolutions from %s (output within %.1g of OpenCV's)" % (loaded, path, err))


def set_training(model, freeze_bn):
    """Training mode; with freeze_bn the batch norms keep their running statistics (fine-tuning
    from folded weights, and small batches)."""
    model.train()
    if freeze_bn:
        for m in model.modules():
            if isinstance(m, nn.BatchNorm2d):
                m.eval()


def build_model(a):
    if a.lite:
        return PipeYOLO(len(CLASSES), 0.5, s4_residual=False, p8_convs=1)
    return PipeYOLO(len(CLASSES), a.width)


# --------------------------------------------------------------------------------------------
# Checkpoints: <out>/<name>.ckpt, written at the end of each epoch, when the budget ends, at
# --stop-after-steps and on SIGINT/SIGTERM. --resume continues from one exactly where it stopped.
CKPT_FORMAT = "drill_pipe_pose train_detector checkpoint"
CKPT_VERSION = 1
# The options that define the network, the schedule and the data order. A resumed run takes them
# from its checkpoint; one given on the command line must agree with it.
RUN_FIELDS = ("finetune", "lite", "width", "smoke", "lr", "schedule_steps", "minutes", "epochs",
              "batch", "crop", "scale_min", "scale_max", "seed")
CKPT_FIELDS = ("format", "version", "model", "optimizer", "epoch", "epoch_step", "order", "step",
               "spent_s", "finished", "running_loss", "args", "n_images", "rng", "best_val_ap",
               "best_val_epoch")


class TrainState:
    """Where training stands: what a checkpoint holds besides the model, the optimiser, the
    run's options and the random generators."""

    def __init__(self):
        self.epoch = 0            # the epoch to continue
        self.epoch_step = 0       # its steps done (0: not started)
        self.order = None         # its image order, once started
        self.step = 0             # steps done in all
        self.spent_s = 0.0        # training time spent [s]: the cosine's clock in minutes mode
        self.finished = False     # the budget (or --epochs) is used up
        self.running_loss = [0.0, 0.0, 0.0]  # this epoch's box, obj, cls loss sums (progress)
        self.best_val_ap = None   # the best validation AP@0.5 (mean over the classes)
        self.best_val_epoch = None


def run_default(field, a):
    """The default of a run-defining option (RUN_FIELDS), given those resolved before it."""
    if field in ("finetune", "smoke", "schedule_steps"):
        return None if field == "schedule_steps" else False
    if field == "lite":
        return bool(a.finetune)
    if field == "width":
        return 0.5 if a.lite else 1.0
    if field == "lr":
        return 5e-4 if a.finetune else 2e-3
    if field == "minutes":  # no minutes budget when --schedule-steps sets one in steps
        return None if a.schedule_steps else 5.0 if a.smoke else 10.0 if a.finetune else 45.0
    return {"epochs": 1 if a.smoke else 1000, "batch": 4 if a.smoke else 16,
            "crop": 128 if a.smoke else 256, "scale_min": 0.5, "scale_max": 1.3, "seed": 0}[field]


def show_option(field, value):
    """How the command line spells a run-defining option's value: --lite, no --lite, --crop 64."""
    opt = "--" + field.replace("_", "-")
    if value is None or isinstance(value, bool):
        return opt if value else "no " + opt
    return "%s %s" % (opt, value)


def resolve_run_args(a, saved, ckpt_path):
    """Fills the run-defining options (None: not given): from the checkpoint's run when resuming
    (one given must agree with it), else their defaults."""
    for f in RUN_FIELDS:
        given = getattr(a, f)
        if saved is not None:
            if f not in saved:
                sys.exit("train_detector: --resume %s: the checkpoint's options lack %s" %
                         (ckpt_path, show_option(f, True)))
            if given is not None and given != saved[f]:
                sys.exit("train_detector: --resume %s: %s contradicts the checkpoint's run (%s); "
                         "leave the option out to take the checkpoint's, or start a new run "
                         "without --resume" % (ckpt_path, show_option(f, given),
                                               show_option(f, saved[f])))
            setattr(a, f, saved[f])
        elif given is None:
            setattr(a, f, run_default(f, a))
    if a.lite and a.width != 0.5:
        sys.exit("train_detector: --width %s: the lite network's width is 0.5 (leave --width out "
                 "with --lite)" % a.width)
    if a.finetune and not a.lite:
        sys.exit("train_detector: --finetune trains the lite network (the shipped one); "
                 "the checkpoint's options say otherwise")


def rng_states(rng):
    """The random generators' states: Python's, numpy's (the augmentation noise), torch's and the
    data-order one (`rng`: shuffling, crops, jitter)."""
    kind, keys, pos, has_gauss, gauss = np.random.get_state()
    return {"python": random.getstate(), "numpy": (kind, keys.tolist(), pos, has_gauss, gauss),
            "torch": torch.get_rng_state(), "data_order": rng.getstate()}


def set_rng_states(states, rng):
    random.setstate(states["python"])
    kind, keys, pos, has_gauss, gauss = states["numpy"]
    np.random.set_state((kind, np.array(keys, dtype=np.uint32), pos, has_gauss, gauss))
    torch.set_rng_state(states["torch"])
    rng.setstate(states["data_order"])


def save_atomic(obj, path):
    """torch.save to a temporary file, then renamed over `path`: a kill mid-write leaves the
    previous file whole."""
    tmp = path + ".tmp"
    with open(tmp, "wb") as f:
        torch.save(obj, f)
        f.flush()
        os.fsync(f.fileno())
    os.replace(tmp, path)


def save_checkpoint(path, a, model, opt, st, n_images, rng):
    ck = {"format": CKPT_FORMAT, "version": CKPT_VERSION, "model": model.state_dict(),
          "optimizer": opt.state_dict(), "args": {f: getattr(a, f) for f in RUN_FIELDS},
          "n_images": n_images, "rng": rng_states(rng)}
    ck.update(vars(st))
    save_atomic(ck, path)


def load_resume_file(path):
    """(checkpoint, None) for a checkpoint of this script, (None, state_dict) for a plain weights
    file (<name>.pt, or a checkpoint from before full resume)."""
    if not os.path.isfile(path):
        sys.exit("train_detector: --resume %s: no such file" % path)
    # A checkpoint is a pickle (numpy's generator state, the optimiser's floats): resume only
    # files of your own. torch >= 2.6 would refuse it by default.
    kw = {"weights_only": False} if "weights_only" in inspect.signature(torch.load).parameters \
        else {}
    try:
        obj = torch.load(path, map_location="cpu", **kw)
    except Exception as e:  # noqa: BLE001 (any reader error: the message names the file)
        sys.exit("train_detector: --resume %s: torch cannot read it (%s)" % (path, e))
    if isinstance(obj, dict) and obj.get("format") == CKPT_FORMAT:
        if obj.get("version") != CKPT_VERSION:
            sys.exit("train_detector: --resume %s: checkpoint version %s, this script reads %d" %
                     (path, obj.get("version"), CKPT_VERSION))
        missing = [f for f in CKPT_FIELDS if f not in obj]
        if missing:
            sys.exit("train_detector: --resume %s: the checkpoint lacks the field(s) %s" %
                     (path, ", ".join(missing)))
        return obj, None
    if isinstance(obj, dict) and obj and all(torch.is_tensor(v) for v in obj.values()):
        return None, obj
    sys.exit("train_detector: --resume %s: neither a checkpoint of this script (<name>.ckpt) nor a "
             "model state_dict (<name>.pt)" % path)


def check_weights_fit(model, weights, path):
    """Exits with a short summary when a state_dict's tensors are not this network's."""
    own = model.state_dict()
    missing = [k for k in own if k not in weights]
    extra = [k for k in weights if k not in own]
    shape = [k for k in own if k in weights and tuple(weights[k].shape) != tuple(own[k].shape)]
    if missing or extra or shape:
        first = ("; first: %s is %s there, %s here" % (shape[0], tuple(weights[shape[0]].shape),
                                                      tuple(own[shape[0]].shape)) if shape else "")
        sys.exit("train_detector: --resume %s: its weights do not fit this network (%d tensors "
                 "missing, %d unexpected, %d of another shape%s); was it trained with another "
                 "--lite/--width?" % (path, len(missing), len(extra), len(shape), first))


def budget_text(a, st):
    if a.schedule_steps:
        return "%d of %d scheduled steps done, %.1f min spent" % (st.step, a.schedule_steps,
                                                                  st.spent_s / 60)
    return "%.1f of %.1f min spent" % (st.spent_s / 60, a.minutes)


def restore(ck, path, a, model, opt, rng):
    """Model, optimiser, random generators and the training state from checkpoint `ck`."""
    model.load_state_dict(ck["model"])
    opt.load_state_dict(ck["optimizer"])
    set_rng_states(ck["rng"], rng)
    st = TrainState()
    for k in vars(st):
        setattr(st, k, ck[k])
    print("resumed from epoch %d step %d, %s%s (%s)" %
          (st.epoch, st.step, budget_text(a, st),
           ": its run is complete, nothing left to train" if st.finished else "", path),
          flush=True)
    return st


# --------------------------------------------------------------------------------------------
# Training
class StopRequest:
    """SIGINT/SIGTERM: the step in progress finishes, the checkpoint is saved and the run exits
    with status 128 + the signal's number. A second signal stops at once (the checkpoint file is
    only ever replaced whole)."""

    def __init__(self):
        self.signum = None

    def install(self):
        for s in (signal.SIGINT, signal.SIGTERM):
            signal.signal(s, self._handle)

    def _handle(self, signum, _frame):
        self.signum = signum
        signal.signal(signum, signal.SIG_DFL)


def learning_rate(a, step, spent_s):
    """Linear warm-up over the first 100 steps, then a cosine from --lr down to 5 % of it over the
    budget: --schedule-steps steps, or else --minutes of training time."""
    frac = step / a.schedule_steps if a.schedule_steps else spent_s / (a.minutes * 60.0)
    frac = min(1.0, frac)
    warm = min(1.0, (step + 1) / 100.0)
    return a.lr * warm * (0.05 + 0.95 * 0.5 * (1 + math.cos(math.pi * frac)))


def budget_used(a, st):
    if a.schedule_steps:
        return st.step >= a.schedule_steps
    return st.spent_s > a.minutes * 60.0


def train_step(a, model, opt, data, st, rng, spent_s):
    for g in opt.param_groups:
        g["lr"] = learning_rate(a, st.step, spent_s)
    k = st.epoch_step
    idx = st.order[k * a.batch:(k + 1) * a.batch]
    imgs, boxes = zip(*[data.sample(i, rng) for i in idx])
    loss, parts = compute_loss(model, to_tensor(imgs), boxes, len(CLASSES))
    opt.zero_grad()
    loss.backward()
    torch.nn.utils.clip_grad_norm_(model.parameters(), 10.0)
    opt.step()
    st.step += 1
    st.epoch_step += 1
    st.running_loss = [r + p for r, p in zip(st.running_loss, parts)]
    if st.step % 50 == 0:
        n = st.epoch_step
        print("epoch %d step %d  box %.3f obj %.4f cls %.3f  lr %.2e  %.0f s (%.1f img/s)" %
              (st.epoch, st.step, st.running_loss[0] / n, st.running_loss[1] / n,
               st.running_loss[2] / n, opt.param_groups[0]["lr"], spent_s,
               st.step * a.batch / max(spent_s, 1e-9)), flush=True)


def validate(a, model, val_items, st, epoch, t0):
    aps, ngt = evaluate(model, val_items, a.eval_scale, len(CLASSES), limit=150)
    set_training(model, a.finetune)
    st.spent_s = time.time() - t0
    known = [v for v in aps if not math.isnan(v)]
    if known and (st.best_val_ap is None or float(np.mean(known)) > st.best_val_ap):
        st.best_val_ap, st.best_val_epoch = float(np.mean(known)), epoch
    print("epoch %d: validation AP@0.5 %s (gt %s), %.0f s; best mean %s" %
          (epoch, " ".join("%s %.3f" % (c, ap) for c, ap in zip(CLASSES, aps)), ngt, st.spent_s,
           "none" if st.best_val_ap is None else "%.3f (epoch %d)" % (st.best_val_ap,
                                                                       st.best_val_epoch)),
          flush=True)


def stop_reason(a, st, stop):
    if stop.signum is not None:
        return signal.Signals(stop.signum).name
    if a.stop_after_steps and st.step >= a.stop_after_steps:
        return "--stop-after-steps %d" % a.stop_after_steps
    return None


def train(a, model, opt, data, val_items, st, rng, stop):
    """Trains until the budget or --epochs is used up; exits (checkpoint saved) at
    --stop-after-steps or on SIGINT/SIGTERM."""
    ckpt = os.path.join(a.out, a.name + ".ckpt")
    steps_per_epoch = max(1, len(data) // a.batch)
    t0 = time.time() - st.spent_s  # time.time() - t0: the training time spent, resumes included
    while not st.finished:
        if st.epoch >= a.epochs:
            st.finished = True
            break
        epoch = st.epoch
        if st.epoch_step == 0:
            st.order = list(range(len(data)))
            rng.shuffle(st.order)
            st.running_loss = [0.0, 0.0, 0.0]
        while (st.epoch_step < steps_per_epoch and not st.finished
               and stop_reason(a, st, stop) is None):
            train_step(a, model, opt, data, st, rng, time.time() - t0)
            st.spent_s = time.time() - t0
            st.finished = budget_used(a, st)
        epoch_done = st.epoch_step >= steps_per_epoch
        if epoch_done or st.finished:
            save_atomic(model.state_dict(), os.path.join(a.out, a.name + ".pt"))
            if val_items and (st.finished or epoch % 3 == 2):
                validate(a, model, val_items, st, epoch, t0)
        if epoch_done:
            st.epoch, st.epoch_step, st.order = epoch + 1, 0, None
            st.finished = st.finished or st.epoch >= a.epochs
        save_checkpoint(ckpt, a, model, opt, st, len(data), rng)
        why = stop_reason(a, st, stop)
        if why:
            print("stopped (%s) at epoch %d step %d, %s: checkpoint %s; continue with --resume %s"
                  % (why, st.epoch, st.step, budget_text(a, st), ckpt, ckpt), flush=True)
            sys.exit(128 + stop.signum if stop.signum is not None else 0)


def parse_args():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawTextHelpFormatter)
    ap.add_argument("--data", help="YOLO dataset root (images/, labels/)")
    ap.add_argument("--finetune", metavar="DATA", dest="finetune_data",
                    help="fine-tune the shipped model (--init-onnx) on this YOLO dataset root "
                         "(label_from_poses' DIR/yolo)")
    ap.add_argument("--init-onnx", default=os.path.join(os.path.dirname(os.path.abspath(__file__)),
                                                        "..", "models", "detector",
                                                        "pipe_yolo.onnx"),
                    help="with --finetune: the exported model to start from")
    ap.add_argument("--data-extra", help="with --finetune: another YOLO dataset root mixed in "
                                         "(e.g. the original renders)")
    ap.add_argument("--split", default="train")
    ap.add_argument("--val", help="YOLO dataset root for validation (default: none)")
    ap.add_argument("--val-split", default="val")
    ap.add_argument("--out", required=True, help="output folder for pipe_yolo.onnx / .pt / .ckpt")
    ap.add_argument("--name", default="pipe_yolo")
    ap.add_argument("--minutes", type=float,
                    help="training time budget [min] (default 45; 10 with --finetune; 5 with "
                         "--smoke)")
    ap.add_argument("--schedule-steps", type=int, metavar="N",
                    help="a budget of N steps instead of minutes: the cosine runs over steps, so a "
                         "run is repeatable (tests)")
    ap.add_argument("--epochs", type=int,
                    help="upper bound on epochs (default 1000; 1 with --smoke)")
    ap.add_argument("--batch", type=int, help="default 16; 4 with --smoke")
    ap.add_argument("--crop", type=int, help="training crop [px] (default 256; 128 with --smoke)")
    ap.add_argument("--scale-min", type=float, help="default 0.5")
    ap.add_argument("--scale-max", type=float, help="default 1.3")
    ap.add_argument("--eval-scale", type=float, default=0.667,
                    help="image scale for the quick validation mAP (1.0: the node's default "
                         "native-size input; 0.667: qHD -> 640 px wide)")
    ap.add_argument("--width", type=float, help="channel width multiplier (default 1.0)")
    ap.add_argument("--lite", action="store_true", default=None,
                    help="the lite network: --width 0.5, no stride-4 residual, one stride-8 conv")
    ap.add_argument("--lr", type=float, help="learning rate (default 2e-3; 5e-4 with --finetune)")
    ap.add_argument("--threads", type=int, default=2)
    ap.add_argument("--seed", type=int, help="default 0")
    ap.add_argument("--export-size", default="416x416", help="ONNX input WxH (any works later)")
    ap.add_argument("--resume", metavar="CKPT",
                    help="continue from a checkpoint (<out>/<name>.ckpt); a plain state_dict "
                         "(<name>.pt) loads the weights only")
    ap.add_argument("--stop-after-steps", type=int, metavar="K",
                    help="save the checkpoint and exit (status 0) once K steps are done in all "
                         "(tests)")
    ap.add_argument("--smoke", action="store_true", default=None,
                    help="CI mode: at most 16 images, one epoch, small crops, export + OpenCV check")
    a = ap.parse_args()
    a.finetune = True if a.finetune_data else None
    if a.finetune_data:
        if a.data:
            ap.error("--finetune DATA replaces --data")
        a.data = a.finetune_data
    if not a.data:
        ap.error("--data (or --finetune) is required")
    if a.minutes is not None and a.schedule_steps is not None:
        ap.error("--schedule-steps replaces --minutes")
    for name in ("schedule_steps", "stop_after_steps", "epochs", "batch", "crop"):
        if getattr(a, name) is not None and getattr(a, name) < 1:
            ap.error("--%s must be at least 1" % name.replace("_", "-"))
    return a


def load_data(a, ck):
    items = read_split(a.data, a.split)
    if a.finetune and a.data_extra:
        items += read_split(a.data_extra, a.split)
    if a.smoke:
        items = items[:16]
    if ck and ck["n_images"] != len(items):
        sys.exit("train_detector: --resume: the training set (%s, split %s) holds %d images, the "
                 "checkpoint's run had %d" % (a.data, a.split, len(items), ck["n_images"]))
    return Samples(items, a.crop, a.scale_min, a.scale_max)


def main():
    a = parse_args()
    ck, weights = load_resume_file(a.resume) if a.resume else (None, None)
    resolve_run_args(a, ck["args"] if ck else None, a.resume)
    torch.set_num_threads(max(1, a.threads))
    random.seed(a.seed)
    np.random.seed(a.seed)
    torch.manual_seed(a.seed)
    rng = random.Random(a.seed)
    data = load_data(a, ck)
    val_items = read_split(a.val, a.val_split) if a.val else []
    model = build_model(a)
    opt = torch.optim.AdamW(model.parameters(), lr=a.lr, weight_decay=5e-4)
    st = TrainState()
    if ck:
        st = restore(ck, a.resume, a, model, opt, rng)
    elif weights is not None:
        check_weights_fit(model, weights, a.resume)
        model.load_state_dict(weights)
        print("warning: --resume %s holds weights only (a state_dict): the optimiser state and the "
              "schedule restart from step 0" % a.resume, flush=True)
    elif a.finetune:
        load_onnx_weights(model, a.init_onnx)
    set_training(model, a.finetune)
    nparams = sum(p.numel() for p in model.parameters())
    print("PipeYOLO: %.3f M parameters, %d training images, crop %d, scale %.2f-%.2f, %s budget, "
          "%d threads" % (nparams / 1e6, len(data), a.crop, a.scale_min, a.scale_max,
                          "%d-step" % a.schedule_steps if a.schedule_steps
                          else "%g min" % a.minutes, a.threads))
    os.makedirs(a.out, exist_ok=True)
    stop = StopRequest()
    stop.install()
    print("checkpoint %s: each epoch; SIGINT/SIGTERM save it and stop" %
          os.path.join(a.out, a.name + ".ckpt"), flush=True)
    train(a, model, opt, data, val_items, st, rng, stop)
    w, h = (int(v) for v in a.export_size.split("x"))
    export_onnx(model, os.path.join(a.out, a.name + ".onnx"), (w, h))
    with open(os.path.join(a.out, "labels.txt"), "w") as f:
        f.write("# Class names of %s.onnx, in model order (one per line).\n" % a.name)
        f.write("\n".join(CLASSES) + "\n")
    print("done: %d steps, %.1f min of training in all" % (st.step, st.spent_s / 60))


if __name__ == "__main__":
    main()
