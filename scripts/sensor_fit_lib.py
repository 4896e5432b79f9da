"""The simulator's sensor model held against real chessboard frames: the fit and the comparison.

Two halves, both driven by scripts/sensor_check:
  fit_sensor_model()  fits the amplitude-dependent effects of the simulator's Kinect v2 model
                      (sim::SensorEffects) to a real recording and prints the values;
  simulate_frames()   renders the same board at every measured real pose with the project's own
                      renderer (the render_board tool, the simulator's depth-effects code) and
                      measures the simulated frames with the same code as the real ones;
  compare_table()     the sim/real table by distance bin, with the targets.

The amplitude scale. The simulator knows a surface's reflectivity r and computes the returned
amplitude as a = r cos(theta) / z^2 [1/m^2]. The real IR image gives amplitude in digital
numbers (DN). The two are tied by one figure, KAPPA: A_DN = KAPPA * a, fixed by giving the
board's white paper the simulator reflectivity WHITE_PAPER_REFLECTIVITY (white office paper
reflects about 80 % in the near infrared). Every amplitude threshold of the model is fitted in
DN and divided by KAPPA.
"""
import csv
import math
import os
import subprocess

import numpy as np

import sensor_check_lib as lib
import sensor_edge_lib as edgelib

WHITE_PAPER_REFLECTIVITY = 0.8   # simulator reflectivity of the board's white paper (NIR, ~80 %)
DARK_LAW_MIN_DIST = 0.75        # [m] where no bright square saturates (sensor_check table)
IR_SATURATION_DN = 60000         # bright-square amplitudes above this are treated as clipped
SIM_CAMERA = dict(width=512, height=424, fx=365.4, fy=365.4, cx=260.9, cy=205.6)  # nominal Kinect v2
BIAS_POWERS = (0.5, 1.0, 1.5, 2.0, 2.5, 3.0, 3.5, 4.0)  # candidate powers of the bias law
MIN_BIN_FRAMES = 10              # a bin counts toward the targets with at least this many frames
DEFAULT_BACKGROUND_M = 0.21      # behind a simulated board whose real frame has no edge measure:
                                 # the recording's median (sensor_check's edge table, 0.21-0.26 m)

# Targets of the comparison (the sensor-realism issue): ratio band, absolute differences.
RATIO_BAND = (0.8, 1.25)
CORR_TOL = 0.1
BIAS_TOL_MM = 2.0
INVALID_TOL = 0.10


def _lstsq(A, y):
    sol, *_ = np.linalg.lstsq(A, y, rcond=None)
    return sol


def ir_amplitudes(folder, res, board=None):
    """Per frame with an IR image: (result dict, bright DN, dark DN), square windows' medians."""
    board = board or lib.Board()
    by_name = {r["frame"]: r for r in res["results"]}
    out = []
    for name in res["names"]:
        path = os.path.join(folder, name + "_ir.png")
        if name not in by_name or not os.path.exists(path):
            continue
        _, corners, ir = lib.load_frame(folder, name)
        a0, a1 = lib.ir_square_amplitudes(ir, res["K"], res["dist"], corners, board)
        bright, dark = (a0, a1) if res["dark_parity"] == 1 else (a1, a0)
        out.append((by_name[name], bright, dark))
    return out


def amplitude_law(rows, which, min_dist=0.0):
    """Least squares log(A z^2) = log k + m log cos(theta) over the unclipped frames at least
    min_dist [m] away: A = k cos^m / z^2, the returned power falling with the square of the
    range (the bright squares alone, fitted freely, give z^-2.03). Returns (k [DN m^2], m, -2,
    rms of log A)."""
    A = np.array([b if which == "bright" else d for _, b, d in rows])
    z = np.array([r["dist_m"] for r, _, _ in rows])
    c = np.cos(np.radians([r["incidence_deg"] for r, _, _ in rows]))
    ok = (A < IR_SATURATION_DN) & (z >= min_dist)
    M = np.stack([np.ones(ok.sum()), np.log(c[ok])], axis=1)
    y = np.log(A[ok] * z[ok] ** 2)
    sol = _lstsq(M, y)
    rms = float(np.sqrt(np.mean((M @ sol - y) ** 2)))
    return float(math.exp(sol[0])), float(sol[1]), -2.0, rms


def amplitude_at(law, z, incidence_deg):
    k, m, p, _ = law
    return k * math.cos(math.radians(incidence_deg)) ** m * z ** p


def fit_sensor_model(folder, res, board=None):
    """Fits the amplitude-dependent effects on a recording. Returns a dict of figures (DN and
    simulator units) and the lines that describe them."""
    rows = ir_amplitudes(folder, res, board)
    if len(rows) < 5:
        raise ValueError(f"{folder}: {len(rows)} frames with an IR image; the fit needs at least 5")
    # The dark squares' law only from frames beyond DARK_LAW_MIN_DIST: nearer, the bright squares
    # saturate and the light they scatter inside the camera raises the dark windows' IR (their
    # free fit there gives z^-1.1, not z^-2).
    bright_law, dark_law = amplitude_law(rows, "bright"), amplitude_law(rows, "dark", DARK_LAW_MIN_DIST)
    kappa = bright_law[0] / WHITE_PAPER_REFLECTIVITY
    f = {"kappa": kappa, "bright_law": bright_law, "dark_law": dark_law, "ir_frames": len(rows)}

    # Noise: sigma^2 = floor^2 + (C / A)^2, floor = the bright squares' spread.
    f["noise_floor_mm"] = float(np.nanmedian([r["bright_sd"] for r in res["results"]]))
    dsd = np.array([r["dark_sd"] for r, _, _ in rows])
    Ad = np.array([d for _, _, d in rows])
    Ab = np.array([b for _, b, _ in rows])
    excess = np.sqrt(np.maximum(dsd ** 2 - f["noise_floor_mm"] ** 2, 1e-6))
    f["noise_c_dn"] = float(np.median(excess * Ad))
    f["noise_c_spread"] = tuple(float(x) for x in np.percentile(excess * Ad, [10, 90]))
    f["noise_power"] = float(np.polyfit(np.log(Ad), np.log(excess), 1)[0])
    f["noise_c_sim"] = f["noise_c_dn"] / kappa

    # Brightness bias: dark - bright = B (A_dark^-p - A_bright^-p), no intercept; the power p
    # from BIAS_POWERS by the least rms (the bias stays near 0 above ~2000 DN and rises steeply
    # below ~1000 DN, so steep powers fit best).
    dmb = np.array([r["dark_minus_bright"] for r, _, _ in rows])
    ok = np.isfinite(dmb)
    best = None
    for p in BIAS_POWERS:
        x = Ad[ok] ** -p - Ab[ok] ** -p
        B = float(x @ dmb[ok] / (x @ x))
        rms = float(np.sqrt(np.mean((B * x - dmb[ok]) ** 2)))
        if best is None or rms < best[2]:
            best = (p, B, rms)
    f["bias_power"], f["bias_b_dn"], f["bias_rms_mm"] = best
    f["bias_frames"] = int(ok.sum())
    f["bias_min_dn"] = float(Ad.min())
    f["bias_b_sim"] = f["bias_b_dn"] * kappa ** -f["bias_power"]
    f["bias_min_sim"] = f["bias_min_dn"] / kappa
    f["bias_max_mm"] = f["bias_b_dn"] * f["bias_min_dn"] ** -f["bias_power"]

    # Saturation: invalid fraction of bright windows against the bright amplitude the law
    # predicts (every measured frame, not only those with an IR image); linear ramp lo -> hi.
    pred = np.array([amplitude_at(bright_law, r["dist_m"], r["incidence_deg"]) for r in res["results"]])
    inv = np.array([r["inv_bright"] for r in res["results"]])
    best = None
    for lo in np.arange(30000, 90000, 1000.0):
        for hi in np.arange(lo + 2000, 130000, 2000.0):
            model = np.clip((pred - lo) / (hi - lo), 0, 1)
            err = float(np.mean((model - inv) ** 2))
            if best is None or err < best[0]:
                best = (err, lo, hi)
    f["sat_lo_dn"], f["sat_hi_dn"], f["sat_rms"] = best[1], best[2], math.sqrt(best[0])
    f["sat_lo_sim"], f["sat_hi_sim"] = best[1] / kappa, best[2] / kappa
    return f


def save_fit(f, path):
    """Writes the fitted figures as JSON (tuples as lists)."""
    import json
    with open(path, "w") as fh:
        json.dump({k: list(v) if isinstance(v, tuple) else v for k, v in f.items()}, fh, indent=1, sort_keys=True)
        fh.write("\n")


def load_fit(path):
    """Reads figures written by save_fit; KeyError names a missing one."""
    import json
    with open(path) as fh:
        f = json.load(fh)
    for k in ("kappa", "bright_law", "dark_law", "noise_floor_mm", "noise_c_dn", "bias_b_dn", "bias_power"):
        if k not in f:
            raise KeyError(f"{path}: no '{k}' (write it with sensor_check --save-fit)")
    for k in ("bright_law", "dark_law", "noise_c_spread"):
        if k in f:
            f[k] = tuple(f[k])
    return f


def fit_lines(f):
    kb, mb, pb, rb = f["bright_law"]
    kd, md, pd, rd = f["dark_law"]
    return [
        f"Sensor model fitted on {f['ir_frames']} frames with an IR image (amplitude = median IR DN of the",
        "square windows; the noise floor and the saturation ramp use every measured frame):",
        f"  bright amplitude  A = {kb:.0f} DN x cos^{mb:.2f} / z^2  (rms {rb:.2f} in log A; unclipped frames)",
        f"  dark amplitude    A = {kd:.0f} DN x cos^{md:.2f} / z^2  (rms {rd:.2f} in log A; frames beyond"
        f" {DARK_LAW_MIN_DIST:g} m)",
        f"  scale: white paper = simulator reflectivity {WHITE_PAPER_REFLECTIVITY:g}, so A_DN = {f['kappa']:.0f} x a,"
        "  a = r cos(theta) / z^2 [1/m^2]",
        f"  noise: sigma^2 = floor^2 + (C / A)^2; floor {f['noise_floor_mm']:.2f} mm (bright-square spread);"
        f" C = {f['noise_c_dn']:.0f} DN mm",
        f"         (10-90 % of frames {f['noise_c_spread'][0]:.0f}-{f['noise_c_spread'][1]:.0f};"
        f" free power law: excess ~ A^{f['noise_power']:.2f}); simulator C = {f['noise_c_sim']:.4f} mm/m^2",
        f"  bias:  dark - bright = B (A_dark^-p - A_bright^-p), p = {f['bias_power']:g} (least rms of"
        f" {', '.join(f'{p:g}' for p in BIAS_POWERS)}),",
        f"         B = {f['bias_b_dn']:.4g} DN^p mm (rms {f['bias_rms_mm']:.1f} mm over {f['bias_frames']} frames);"
        f" simulator B = {f['bias_b_sim'] * 1e-3:.4g} m (1/m^2)^p;",
        f"         held below the lowest fitted amplitude {f['bias_min_dn']:.0f} DN = a {f['bias_min_sim']:.4f}"
        f" (bias there {f['bias_max_mm']:.1f} mm)",
        f"  saturation: bright windows invalid on a ramp from {f['sat_lo_dn']:.0f} to {f['sat_hi_dn']:.0f} DN"
        f" (rms {f['sat_rms']:.2f}); simulator a {f['sat_lo_sim']:.2f}-{f['sat_hi_sim']:.2f} 1/m^2",
    ]


def frame_reflectivities(f, r):
    """Simulator reflectivities of the bright and dark squares that give a real frame's fitted
    amplitudes at its distance and incidence (the target's own angular reflectance is taken
    from the IR images, so that the comparison tests the sensor model, not the paper)."""
    c = math.cos(math.radians(r["incidence_deg"]))
    z = r["dist_m"]
    conv = z * z / (f["kappa"] * c)
    bright = amplitude_at(f["bright_law"], z, r["incidence_deg"]) * conv
    dark = amplitude_at(f["dark_law"], z, r["incidence_deg"]) * conv
    return min(bright, 1.0), min(dark, 1.0)


def background_behind(r):
    """The plane behind the simulated board [m along its normal]: what the real frame's edges
    found behind the board (along z, hence the cosine), else DEFAULT_BACKGROUND_M."""
    back = r.get("edge_back_mm", float("nan"))
    if not np.isfinite(back):
        return DEFAULT_BACKGROUND_M
    return back / 1000.0 * math.cos(math.radians(r["incidence_deg"]))


def simulate_frames(tool, res, f, out_dir, profile="kinect_v2_calibrated", seed=1, off=(), board=None,
                    edges=True, params=(), repeat=2, quiet=False, edges_before_refit=False):
    """Renders every measured real pose twice (two noise draws) with `tool` (render_board) and
    measures the simulated frames like the real ones (with edges, the edge measures too, before
    a plane as far behind the board as the real frame's edges found). Returns (results, temporal)."""
    board = board or lib.Board()
    os.makedirs(out_dir, exist_ok=True)
    poses = os.path.join(out_dir, "poses.csv")
    import cv2
    with open(poses, "w", newline="") as fh:
        w = csv.writer(fh)
        w.writerow(["frame", "rx", "ry", "rz", "tx", "ty", "tz", "bright_reflectivity", "dark_reflectivity",
                    "background_behind"])
        for r in res["results"]:
            rvec, _ = cv2.Rodrigues(r["R"])
            rb, rd = frame_reflectivities(f, r)
            w.writerow([r["frame"]] + [f"{v:.9g}" for v in rvec.ravel()] + [f"{v:.9g}" for v in r["t"]]
                       + [f"{rb:.6g}", f"{rd:.6g}", f"{background_behind(r):.6g}"])
    cmd = [tool, "--poses", poses, "--out", out_dir, "--profile", profile, "--seed", str(seed),
           "--repeat", str(repeat), "--margin-reflectivity-ratio", f"{res.get('margin_ratio', 1.0):.4g}",
           "--dark-parity", str(res["dark_parity"]),
           "--cols", str(board.cols), "--rows", str(board.rows), "--square", str(board.square)]
    for k, v in SIM_CAMERA.items():
        cmd += [f"--{k}", str(v)]
    for e in off:
        cmd += ["--off", e]
    if edges_before_refit:
        cmd.append("--edges-before-refit")
    for p in params:
        cmd += ["--sensor-param", p]
    run = subprocess.run(cmd, stdout=subprocess.DEVNULL, stderr=subprocess.PIPE if quiet else None,
                         universal_newlines=True)
    if run.returncode != 0:
        raise ValueError(f"{' '.join(cmd)} exited with {run.returncode}" + (
            f": {run.stderr.strip()[-2000:]}" if quiet and run.stderr else ""))
    K = np.array([[SIM_CAMERA["fx"], 0, SIM_CAMERA["cx"]], [0, SIM_CAMERA["fy"], SIM_CAMERA["cy"]], [0, 0, 1]])
    dist = np.zeros(5)
    corners = {}
    with open(os.path.join(out_dir, "corners.csv")) as fh:
        for row in csv.DictReader(fh):
            corners.setdefault(row["frame"], []).append((int(row["i"]), float(row["u"]), float(row["v"])))
    results, temporal, frames = [], [], {}
    real_groups = {t["frames_names"][0]: t for _, t in res["temporal"]}
    for r in res["results"]:
        name = r["frame"]
        c = np.array([uv for _, *uv in sorted(corners[name])])
        files = [f"{name}_0.pgm", f"{name}_1.pgm"] if repeat > 1 else [f"{name}.pgm"] * 2
        d0, d1 = (cv2.imread(os.path.join(out_dir, fn), cv2.IMREAD_ANYDEPTH) for fn in files)
        if d0 is None or d1 is None:
            raise ValueError(f"{out_dir}: the simulated frame {name} was not written")
        m = lib.measure_frame(d0, K, dist, c, board, res["dark_parity"])
        m["frame"] = name
        results.append(m)
        frames[name], frames[name + "_0"], frames[name + "_1"] = (d0, c), (d0, c), (d1, c)
        if name in real_groups and repeat > 1:
            t = lib.temporal_measures([d0, d1], K, dist, c, board, res["dark_parity"])
            t["frames_names"] = [name + "_0", name + "_1"]
            temporal.append((m["dist_m"], t))
    if edges:
        edgelib.add_edges(frames.__getitem__, results, temporal, K, dist, board)
    return results, temporal


COMPARE = [
    # key, label, kind (ratio | diff), scale, tolerance
    ("resid_std", "plane sd", "ratio", 1, RATIO_BAND),
    ("bright_sd", "bright sd", "ratio", 1, RATIO_BAND),
    ("dark_sd", "dark sd", "ratio", 1, RATIO_BAND),
    ("temporal_sd", "temporal sd", "ratio", 1, RATIO_BAND),
    ("corr_sq", "corr sq", "diff", 1, CORR_TOL),
    ("dark_minus_bright", "dark-bri mm", "diff", 1, BIAS_TOL_MM),
    ("inv_bright", "inv bri %", "diff", 100, INVALID_TOL * 100),
    ("inv_dark", "inv dark %", "diff", 100, INVALID_TOL * 100),
]


def compare_rows(real_rows, sim_rows):
    """Per bin and measure: (bin, n, key, real, sim, value, ok) where value is sim/real or
    sim - real; ok is None where the bin has fewer than MIN_BIN_FRAMES frames or a side has no
    value (the target does not apply)."""
    sim = {b: agg for b, _, agg in sim_rows}
    out = []
    for b, n, agg in real_rows:
        s = sim.get(b)
        for key, label, kind, scale, tol in COMPARE:
            rv = agg.get(key, float("nan"))
            sv = s.get(key, float("nan")) if s else float("nan")
            if not (np.isfinite(rv) and np.isfinite(sv)):
                out.append((b, n, key, rv, sv, float("nan"), None))
                continue
            if kind == "ratio":
                val = sv / rv
                ok = tol[0] <= val <= tol[1]
            else:
                val = (sv - rv) * scale
                ok = abs(val) <= tol
            out.append((b, n, key, rv * scale, sv * scale, val, ok if n >= MIN_BIN_FRAMES else None))
    return out


def format_compare(rows, markdown=False):
    labels = {k: (lbl, kind) for k, lbl, kind, _, _ in COMPARE}
    head = ["distance m", "n", "measure", "real", "sim", "sim/real or sim-real", "target"]
    body = []
    for b, n, key, rv, sv, val, ok in rows:
        lbl, kind = labels[key]
        fmt = "{:.2f}"
        cells = [f"{b[0]:.2f}-{b[1]:.2f}", str(n), lbl,
                 fmt.format(rv) if np.isfinite(rv) else "-", fmt.format(sv) if np.isfinite(sv) else "-",
                 (f"{val:.2f}" if kind == "ratio" else f"{val:+.2f}") if np.isfinite(val) else "-",
                 "-" if ok is None else ("ok" if ok else "MISS")]
        body.append(cells)
    if markdown:
        lines = ["| " + " | ".join(head) + " |", "|" + "|".join("---" for _ in head) + "|"]
        lines += ["| " + " | ".join(c) + " |" for c in body]
        return "\n".join(lines)
    widths = [max(len(h), *(len(c[i]) for c in body)) for i, h in enumerate(head)]
    lines = ["  ".join(h.rjust(w) for h, w in zip(head, widths))]
    lines += ["  ".join(x.rjust(w) for x, w in zip(c, widths)) for c in body]
    return "\n".join(lines)


def compare_text():
    lo, hi = RATIO_BAND
    return (f"Targets, in every 0.25 m bin with at least {MIN_BIN_FRAMES} frames: sim/real within {lo}-{hi} for the\n"
            f"spreads (plane sd, bright sd, dark sd, temporal sd), sim - real within {CORR_TOL} for corr sq,\n"
            f"{BIAS_TOL_MM:g} mm for dark-bri, {INVALID_TOL * 100:g} points for the invalid fractions. The simulated board\n"
            "is the real one (5 x 7 inner corners, 30 mm squares, dark parity as found) at each real frame's\n"
            "PnP pose, rendered by render_board through the simulator's depth effects with the nominal\n"
            "Kinect v2 intrinsics and no distortion, each square with the reflectivity that gives the fitted\n"
            "amplitude of that frame; two noise draws per pose (the second only for the temporal spread,\n"
            "at the real repeated poses).")


# --------------------------------------------------------------------------------------------
# The edge model (lateral noise and mixed pixels at depth edges) fitted to the board's edges.

# The search: every parameter in turn over its grid, the others held, EDGE_FIT_PASSES times.
# The mixed-pixel shape is fixed (amplitude-weighted: the edge table's mixed pixels fall near
# the board, the brighter return, at t = 0.19-0.28, where a plain fraction would put them at 0.5).
EDGE_GRID = [
    ("lateral_noise_px", [0.1, 0.2, 0.3, 0.4, 0.5, 0.6, 0.8]),
    ("edge_invalid_probability", [0.3, 0.4, 0.45, 0.5, 0.55, 0.6, 0.7]),
    ("flying_probability", [0.2, 0.3, 0.4, 0.45, 0.5, 0.6, 0.7]),
    ("flying_weight_min", [0.0, 0.1, 0.2, 0.3]),
    ("flying_weight_max", [0.5, 0.6, 0.7, 0.8, 1.0]),
]
EDGE_START = dict(lateral_noise_px=0.8, edge_invalid_probability=0.5, flying_probability=0.5,
                  flying_weight_min=0.0, flying_weight_max=1.0)
EDGE_FIT_PASSES = 2
EDGE_FIT_MEASURES = ("mixed share", "mixed/cross", "invalid/cross", "edge sd px", "mixed t median")


def edge_params(values):
    """--sensor-param assignments of an edge model."""
    return [f"{k}={v:g}" for k, v in values.items()] + ["flying_amplitude_weighted=1"]


def edge_score(real_rows, sim_rows):
    """Sum over bins with the target and the fitted measures of log(sim/real)^2."""
    rows = [r for r in edgelib.compare_edges(real_rows, sim_rows)
            if r[6] is not None and r[2] in EDGE_FIT_MEASURES]
    return float(sum(math.log(max(r[5], 0.05)) ** 2 for r in rows))


def _edge_eval(job):
    tool, res, f, board, values, out_dir = job
    sim, _ = simulate_frames(tool, res, f, out_dir, params=edge_params(values), repeat=1, board=board,
                             quiet=True)
    return edgelib.edge_bin_table(sim)


def fit_edge_model(tool, res, f, work_dir, board=None, jobs=2, log=print):
    """Fits the edge model's parameters to res's edge measures (edgelib.add_edges first) by a
    coordinate search over EDGE_GRID (each candidate: every measured pose rendered once through
    render_board). Returns (values, score, trace [(values, score)])."""
    import multiprocessing
    real_rows = edgelib.edge_bin_table(res["results"])
    cache = {}
    best = dict(EDGE_START)
    trace = []

    def evaluate(cands):
        todo = [c for c in cands if tuple(sorted(c.items())) not in cache]
        jobs_ = [(tool, res, f, board, c, os.path.join(work_dir, f"cand{len(cache) + i}"))
                 for i, c in enumerate(todo)]
        with multiprocessing.Pool(max(1, jobs)) as pool:
            for c, rows in zip(todo, pool.map(_edge_eval, jobs_)):
                cache[tuple(sorted(c.items()))] = edge_score(real_rows, rows)
                trace.append((dict(c), cache[tuple(sorted(c.items()))]))
                log(f"  edge fit {len(cache):3d}: " + " ".join(f"{k}={v:g}" for k, v in c.items())
                    + f"  score {trace[-1][1]:.3f}")
        return [cache[tuple(sorted(c.items()))] for c in cands]

    best_score = evaluate([best])[0]
    for _ in range(EDGE_FIT_PASSES):
        for key, grid in EDGE_GRID:
            cands = [dict(best, **{key: v}) for v in grid]
            cands = [c for c in cands if c["flying_weight_min"] < c["flying_weight_max"]]
            scores = evaluate(cands)
            k = int(np.argmin(scores))
            if scores[k] < best_score:
                best, best_score = cands[k], scores[k]
    return best, best_score, trace
