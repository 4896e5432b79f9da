#!/usr/bin/env python3
"""Converts annotated images between Pascal VOC and YOLO formats (e.g. real rig images labelled
in a VOC tool such as labelImg, for training or evaluating the pipe_detector's model).

    voc_yolo.py voc2yolo VOC_ROOT YOLO_ROOT [--split train] [--classes box_end,pin_end] [--copy]
    voc_yolo.py yolo2voc YOLO_ROOT VOC_ROOT [--split train] [--classes box_end,pin_end] [--copy]

VOC layout: JPEGImages/<name>.jpg, Annotations/<name>.xml, ImageSets/Main/<split>.txt (optional:
without it every annotation is converted). VOC boxes are 1-based inclusive pixel corners.
YOLO layout: images/<split>/<name>.jpg, labels/<split>/<name>.txt with one `class cx cy w h` line
per box (normalised to [0, 1]), classes.txt. Images are symlinked unless --copy.
Unknown class names are an error naming the file and the name; `difficult` boxes are kept.
"""

import argparse
import os
import shutil
import sys
import xml.etree.ElementTree as ET

IMAGE_EXTS = (".jpg", ".jpeg", ".png", ".bmp")


def place(src, dst, copy):
    if os.path.lexists(dst):
        os.remove(dst)
    if copy:
        shutil.copyfile(src, dst)
    else:
        os.symlink(os.path.abspath(src), dst)


def find_image(folder, stem):
    for ext in IMAGE_EXTS:
        p = os.path.join(folder, stem + ext)
        if os.path.exists(p):
            return p
    return None


def voc2yolo(voc, yolo, split, classes, copy):
    ann_dir = os.path.join(voc, "Annotations")
    img_dir = os.path.join(voc, "JPEGImages")
    if not os.path.isdir(ann_dir):
        sys.exit("voc_yolo: %s is not a VOC dataset (no Annotations/)" % voc)
    list_file = os.path.join(voc, "ImageSets", "Main", split + ".txt")
    if os.path.exists(list_file):
        names = [l.strip() for l in open(list_file) if l.strip()]
    else:
        names = sorted(os.path.splitext(f)[0] for f in os.listdir(ann_dir) if f.endswith(".xml"))
    os.makedirs(os.path.join(yolo, "images", split), exist_ok=True)
    os.makedirs(os.path.join(yolo, "labels", split), exist_ok=True)
    n_boxes = 0
    for name in names:
        xml_path = os.path.join(ann_dir, name + ".xml")
        try:
            root = ET.parse(xml_path).getroot()
        except (ET.ParseError, OSError) as e:
            sys.exit("voc_yolo: %s: %s" % (xml_path, e))
        size = root.find("size")
        if size is None:
            sys.exit("voc_yolo: %s: no <size>" % xml_path)
        w = float(size.findtext("width", "0"))
        h = float(size.findtext("height", "0"))
        if w <= 0 or h <= 0:
            sys.exit("voc_yolo: %s: <size> width/height must be > 0" % xml_path)
        lines = []
        for obj in root.findall("object"):
            cls = obj.findtext("name", "").strip()
            if cls not in classes:
                sys.exit("voc_yolo: %s: class '%s' is not one of %s" % (xml_path, cls, classes))
            bb = obj.find("bndbox")
            x0, y0 = float(bb.findtext("xmin")) - 1, float(bb.findtext("ymin")) - 1
            x1, y1 = float(bb.findtext("xmax")), float(bb.findtext("ymax"))
            if not (0 <= x0 < x1 <= w and 0 <= y0 < y1 <= h):
                sys.exit("voc_yolo: %s: box %s (%g, %g, %g, %g) outside the %gx%g image" %
                         (xml_path, cls, x0 + 1, y0 + 1, x1, y1, w, h))
            lines.append("%d %.6f %.6f %.6f %.6f" % (classes.index(cls), (x0 + x1) / 2 / w,
                                                      (y0 + y1) / 2 / h, (x1 - x0) / w,
                                                      (y1 - y0) / h))
        img = find_image(img_dir, name)
        if img is None:
            sys.exit("voc_yolo: no image for %s in %s" % (name, img_dir))
        place(img, os.path.join(yolo, "images", split, os.path.basename(img)), copy)
        with open(os.path.join(yolo, "labels", split, name + ".txt"), "w") as f:
            f.write("\n".join(lines) + ("\n" if lines else ""))
        n_boxes += len(lines)
    with open(os.path.join(yolo, "classes.txt"), "w") as f:
        f.write("\n".join(classes) + "\n")
    print("voc_yolo: %d images, %d boxes -> %s (split %s)" % (len(names), n_boxes, yolo, split))


def yolo2voc(yolo, voc, split, classes, copy):
    img_dir = os.path.join(yolo, "images", split)
    lab_dir = os.path.join(yolo, "labels", split)
    if not os.path.isdir(img_dir):
        sys.exit("voc_yolo: %s is not a YOLO dataset (no images/%s)" % (yolo, split))
    try:
        import cv2  # only for image sizes
    except ImportError:
        sys.exit("voc_yolo: yolo2voc needs python3-opencv for the image sizes")
    for d in ("JPEGImages", "Annotations", os.path.join("ImageSets", "Main")):
        os.makedirs(os.path.join(voc, d), exist_ok=True)
    names, n_boxes = [], 0
    for fname in sorted(os.listdir(img_dir)):
        stem, ext = os.path.splitext(fname)
        if ext.lower() not in IMAGE_EXTS:
            continue
        img_path = os.path.join(img_dir, fname)
        img = cv2.imread(img_path)
        if img is None:
            sys.exit("voc_yolo: cannot read image %s" % img_path)
        h, w = img.shape[:2]
        ann = ET.Element("annotation")
        ET.SubElement(ann, "folder").text = "JPEGImages"
        ET.SubElement(ann, "filename").text = fname
        size = ET.SubElement(ann, "size")
        ET.SubElement(size, "width").text = str(w)
        ET.SubElement(size, "height").text = str(h)
        ET.SubElement(size, "depth").text = str(img.shape[2] if img.ndim == 3 else 1)
        ET.SubElement(ann, "segmented").text = "0"
        lab_path = os.path.join(lab_dir, stem + ".txt")
        if os.path.exists(lab_path):
            for ln, line in enumerate(open(lab_path), 1):
                v = line.split()
                if not v:
                    continue
                if len(v) != 5:
                    sys.exit("voc_yolo: %s:%d: expected 'class cx cy w h'" % (lab_path, ln))
                c = int(v[0])
                if not 0 <= c < len(classes):
                    sys.exit("voc_yolo: %s:%d: class %d outside 0..%d (%s)" %
                             (lab_path, ln, c, len(classes) - 1, classes))
                cx, cy, bw, bh = (float(x) for x in v[1:])
                obj = ET.SubElement(ann, "object")
                ET.SubElement(obj, "name").text = classes[c]
                ET.SubElement(obj, "pose").text = "Unspecified"
                ET.SubElement(obj, "truncated").text = "0"
                ET.SubElement(obj, "difficult").text = "0"
                bb = ET.SubElement(obj, "bndbox")
                ET.SubElement(bb, "xmin").text = str(int(round((cx - bw / 2) * w)) + 1)
                ET.SubElement(bb, "ymin").text = str(int(round((cy - bh / 2) * h)) + 1)
                ET.SubElement(bb, "xmax").text = str(int(round((cx + bw / 2) * w)))
                ET.SubElement(bb, "ymax").text = str(int(round((cy + bh / 2) * h)))
                n_boxes += 1
        ET.ElementTree(ann).write(os.path.join(voc, "Annotations", stem + ".xml"))
        place(img_path, os.path.join(voc, "JPEGImages", fname), copy)
        names.append(stem)
    with open(os.path.join(voc, "ImageSets", "Main", split + ".txt"), "w") as f:
        f.write("\n".join(names) + ("\n" if names else ""))
    print("voc_yolo: %d images, %d boxes -> %s (split %s)" % (len(names), n_boxes, voc, split))


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawTextHelpFormatter)
    ap.add_argument("direction", choices=["voc2yolo", "yolo2voc"])
    ap.add_argument("src")
    ap.add_argument("dst")
    ap.add_argument("--split", default="train")
    ap.add_argument("--classes", default="box_end,pin_end")
    ap.add_argument("--copy", action="store_true", help="copy images instead of symlinking")
    a = ap.parse_args()
    classes = [c for c in a.classes.split(",") if c]
    (voc2yolo if a.direction == "voc2yolo" else yolo2voc)(a.src, a.dst, a.split, classes, a.copy)


if __name__ == "__main__":
    main()
