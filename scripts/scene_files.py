"""What the bench scripts read from a scene file (config/scenes/<scene>.yaml) and from
bench_estimator's output, in one place."""
import os

import yaml

REPO = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))


def scene_path(scene):
    """The scene file of `scene` (a name such as thesis_vertical)."""
    return os.path.join(REPO, "config", "scenes", scene + ".yaml")


def work_zone_args(scene):
    """The scene file's work zone as bench_estimator's --work-zone arguments (min, then max)."""
    with open(scene_path(scene)) as f:
        wz = yaml.safe_load(f)["work_zone"]
    return [f"{v:g}" for v in wz["min"] + wz["max"]]


def tagged_lines(output, tag):
    """The key=value fields of each of bench_estimator's output lines that start with `tag`
    (TYPE, ENDTYPE, RESULT, ...), as dicts of strings."""
    return [dict(t.split("=", 1) for t in line.split()[1:] if "=" in t)
            for line in output.splitlines() if line.startswith(tag + " ")]
