"""Measurements of depth on a chessboard, for real and simulated Kinect v2 frames alike.

Importable by scripts/sensor_check (the real-data table) and by test/test_sensor_check.py; a
simulator-side driver feeds its own frames through measure_frame() and temporal_measures() at
the same poses and intrinsics, so both sides are measured by the same code.

Only numpy and cv2 (OpenCV 4) are needed. Units: depth images in millimetres (uint16, 0 =
invalid), pixel coordinates in raw (distorted) image pixels, board geometry in metres; every
returned measure is in millimetres, a fraction, or metres as its key says.

PROCEDURE (printed by scripts/sensor_check; it is the definition of the measures) is kept
below, next to the code that implements it.
"""
import glob
import math
import os
import re

import cv2
import numpy as np
import yaml

# --------------------------------------------------------------------------------------------
# Defaults (every one of them is printed with the procedure).
WINDOW_MARGIN = 0.2      # local window: a square's central part, this fraction of the side cut at each edge
OUTLIER_K = 3.0          # plane fit: reject |e - median(e)| > K * 1.4826 * MAD(e)
OUTLIER_ITERS = 10       # at most this many refits (stops when the inlier set no longer changes)
MIN_SQUARE_PIXELS = 4    # a square's window counts for the spread only with this many inlier pixels
REPEAT_PX = 0.5          # frames repeat a pose when no corner moved more than this [px]
PNP_GATE_MM = 80.0       # depth-vs-PnP offset uses pixels within this of the PnP plane (as upstream)
BIN_M = 0.25             # distance bins [m]
MAX_REPROJ_PX = 0.5      # frames whose PnP mean reprojection error exceeds this are left out (misplaced corners)

PROCEDURE = """\
Procedure (this text is the definition of every measure in the table)
  Input per frame: raw depth image (mm, 0 = invalid, not rectified), the {ncorner} chessboard
  corners found in the IR image of the same sensor (raw pixels), the IR intrinsics and 5
  distortion coefficients, the board ({cols} x {rows} inner corners, {square_mm:g} mm squares).
  1. Board pose: cv2.solvePnP (iterative) of the board corners, corner i at board coordinates
     ((i mod {cols}) s, (i div {cols}) s, 0), s = square side; the order is checked (corner 1 - corner 0
     and corner {cols} - corner 0 are the two board axes). A frame whose mean reprojection error
     exceeds {maxrep:g} px is left out and listed (a misplaced corner: the gap in this data is
     0.29 -> 1.15 px).
  2. Pixels: those whose centre lies inside the convex hull of the raw corner pixels. Each pixel
     ray is undistorted with the same intrinsics: r = (x', y', 1); the 3D point is depth * r
     (Kinect depth is z, not range). Board coordinates of a pixel: its ray cut with the PnP board
     plane, in the board frame; its square is (floor(u/s), floor(v/s)).
  3. Square colour: a square is dark when (i + j) mod 2 = P, the dark parity. P is found from the
     IR amplitude images (the parity whose square windows have the lower median amplitude, every
     IR frame voting) and then used for every frame; with 5 x 7 inner corners the pattern is the
     same under the 180-degree ambiguity of the corner order, so one P serves all frames.
  4. Plane fit: least squares Z = A + B X + C Y of the 3D points of the valid hull pixels,
     refitted up to {iters} times on the inliers. Outlier rule, applied separately to the pixels
     of dark and of bright squares (so the dark/bright bias stays in): |e - median(e)| >
     {k:g} x 1.4826 x MAD(e) over that colour's current inliers, with e the residual along the
     pixel ray (measured minus plane, positive = farther).
       resid_std    std of e over the inliers, along the RAY [mm] (reported; ToF measures range);
                    the z version (resid_std_z) is also returned; the two differ by |r| <= 1.06 here.
       outliers     fraction of valid hull pixels rejected by the rule.
  5. Local window: the central part of each square, {margin:g} of the side cut at each of its four
     edges (the central {inner:.0%} x {inner:.0%}); only plane-fit inliers; a square counts with
     at least {minpix} such pixels. Each square's own mean of e is removed (per-square-demeaned e).
       bright_sd / dark_sd   pooled std of the per-square-demeaned e over bright / dark windows,
                    sqrt(sum d^2 / sum (n_sq - 1)) [mm]; dark/bright is their ratio.
       corr_sq      neighbour-pixel correlation of the per-square-demeaned e: sum(a b) /
                    sqrt(sum a^2 sum b^2) over horizontally and vertically adjacent pixel pairs
                    inside the same window (pooled over both directions).
       corr_plane   the same over adjacent inlier pairs of the hull, on e itself (not demeaned).
       dark-bright  mean e over dark windows minus mean e over bright windows [mm] (+ = dark farther).
       inv_bright / inv_dark  fraction of window pixels with depth 0 in bright / dark squares
                    (all window pixels, before any fit).
  6. Depth against the PnP plane: z - z_pnp along z for the valid hull pixels within
     {gate:g} mm of the PnP plane (the upstream depth-calibration gate); offset = their mean [mm]
     (+ = depth reads farther than the pose from the corners). Upstream kinect2_calibration
     stores depthShift = mean(z_pnp - z) over the same kind of pixels, so depthShift is expected
     near -offset. Growth with range: least squares offset = a + b (dist - 1 m) over the frames.
  7. Temporal: frames repeat a pose when no corner moves more than {repeat:g} px between them;
     for each such group, the per-pixel std across the frames (valid in all, in the hull),
     pooled over pixels (unbiased), after removing each frame's median difference to the group
     mean; temporal corr = neighbour correlation of the difference of two frames.
  8. Distance = z of the board centre from PnP [m]; bins of {bin:g} m; a bin's value is the MEDIAN
     over its frames of the per-frame measures (a few frames at 30+ degrees carry dark-square
     biases of several cm that would swamp a mean) (temporal: pooled over the groups in the bin);
     n = frames in the bin.
"""


def procedure_text(board=None):
    board = board or Board()
    return PROCEDURE.format(ncorner=board.cols * board.rows, cols=board.cols, rows=board.rows,
                            square_mm=board.square * 1000, iters=OUTLIER_ITERS, k=OUTLIER_K,
                            margin=WINDOW_MARGIN, inner=1 - 2 * WINDOW_MARGIN,
                            minpix=MIN_SQUARE_PIXELS, gate=PNP_GATE_MM, repeat=REPEAT_PX,
                            bin=BIN_M, maxrep=MAX_REPROJ_PX)


class Board:
    """A chessboard's inner-corner grid: cols corners along a row, rows rows, square side [m]."""

    def __init__(self, cols=5, rows=7, square=0.030):
        self.cols, self.rows, self.square = cols, rows, square

    def object_points(self):
        i = np.arange(self.cols * self.rows)
        return np.stack([(i % self.cols) * self.square, (i // self.cols) * self.square,
                         np.zeros(i.size)], axis=1).astype(np.float64)

    def centre(self):
        return np.array([(self.cols - 1) / 2 * self.square, (self.rows - 1) / 2 * self.square, 0.0])


# --------------------------------------------------------------------------------------------
# Reading the data folder (OpenCV YAML as written by the kinect2 tools).

def read_cv_yaml(path):
    with open(path) as f:
        text = f.read()
    text = re.sub(r"^%YAML[: ]1\.0\s*\n", "", text)
    text = text.replace("!!opencv-matrix", "")
    return yaml.safe_load(text)


def _matrix(node):
    return np.array(node["data"], dtype=np.float64).reshape(node["rows"], node["cols"])


def read_intrinsics(path):
    """(K 3x3, dist 1x5) from a calib_ir.yaml."""
    y = read_cv_yaml(path)
    return _matrix(y["cameraMatrix"]), _matrix(y["distortionCoefficients"]).ravel()


def read_corners(path):
    return np.array(read_cv_yaml(path)["points"], dtype=np.float64).reshape(-1, 2)


def read_depth_shift(path):
    return float(read_cv_yaml(path)["depthShift"])


def list_frames(folder):
    """Frame names (NNNN) that have both NNNN_depth.png and NNNN_ir_points.yaml."""
    names = []
    for p in sorted(glob.glob(os.path.join(folder, "*_depth.png"))):
        name = os.path.basename(p)[:-len("_depth.png")]
        if os.path.exists(os.path.join(folder, name + "_ir_points.yaml")):
            names.append(name)
    return names


def load_frame(folder, name):
    depth = cv2.imread(os.path.join(folder, name + "_depth.png"), cv2.IMREAD_UNCHANGED)
    if depth is None or depth.dtype != np.uint16:
        raise ValueError(f"{name}_depth.png: not a 16-bit image")
    corners = read_corners(os.path.join(folder, name + "_ir_points.yaml"))
    ir_path = os.path.join(folder, name + "_ir.png")
    ir = cv2.imread(ir_path, cv2.IMREAD_UNCHANGED) if os.path.exists(ir_path) else None
    return depth, corners, ir


# --------------------------------------------------------------------------------------------
# Geometry.

_RAY_CACHE = {}


def pixel_rays(shape, K, dist):
    """Undistorted normalised rays (x', y') of every pixel centre, shape (h, w, 2); cached."""
    key = (shape, K.tobytes(), np.asarray(dist).tobytes())
    if key not in _RAY_CACHE:
        h, w = shape
        xs, ys = np.meshgrid(np.arange(w, dtype=np.float64), np.arange(h, dtype=np.float64))
        pts = np.stack([xs.ravel(), ys.ravel()], axis=1).reshape(-1, 1, 2)
        und = cv2.undistortPointsIter(pts, K, np.asarray(dist, dtype=np.float64), None, None,
                                      (cv2.TERM_CRITERIA_COUNT | cv2.TERM_CRITERIA_EPS, 40, 1e-10))
        _RAY_CACHE[key] = und.reshape(h, w, 2)
    return _RAY_CACHE[key]


def board_pose(corners, K, dist, board):
    """PnP pose of the board: (R, t [m], mean reprojection error [px])."""
    obj = board.object_points()
    ok, rvec, tvec = cv2.solvePnP(obj, corners.reshape(-1, 1, 2), K, np.asarray(dist),
                                  flags=cv2.SOLVEPNP_ITERATIVE)
    if not ok:
        raise ValueError("solvePnP failed")
    proj, _ = cv2.projectPoints(obj, rvec, tvec, K, np.asarray(dist))
    err = float(np.mean(np.linalg.norm(proj.reshape(-1, 2) - corners, axis=1)))
    R, _ = cv2.Rodrigues(rvec)
    return R, tvec.ravel(), err


def check_corner_order(corners, board):
    """Checks that the corners run row by row, `cols` to a row, as a regular grid (raises if not):
    within a row consecutive corners step alike, and rows step alike."""
    g = corners.reshape(board.rows, board.cols, 2)
    along = np.diff(g, axis=1)           # along rows
    across = np.diff(g, axis=0)          # across rows
    la, lc = np.linalg.norm(along, axis=2), np.linalg.norm(across, axis=2)
    if la.min() <= 0 or lc.min() <= 0:
        raise ValueError("repeated corners")
    # Every step along a row points the same way as the median step along rows (and likewise
    # across rows), and the two axes are not parallel. A single misplaced corner passes this
    # check; it shows in the PnP reprojection error instead (MAX_REPROJ_PX).
    ax, cx = np.median(along.reshape(-1, 2), axis=0), np.median(across.reshape(-1, 2), axis=0)
    cos_a = (along.reshape(-1, 2) @ ax) / (la.ravel() * np.linalg.norm(ax))
    cos_c = (across.reshape(-1, 2) @ cx) / (lc.ravel() * np.linalg.norm(cx))
    sin_axes = abs(ax[0] * cx[1] - ax[1] * cx[0]) / (np.linalg.norm(ax) * np.linalg.norm(cx))
    if cos_a.min() < 0.5 or cos_c.min() < 0.5 or sin_axes < 0.5:
        raise ValueError("corners are not a row-major %dx%d grid" % (board.cols, board.rows))


def hull_mask(shape, corners):
    """Pixels whose centre is inside the convex hull of the corners (sub-pixel polygon)."""
    hull = cv2.convexHull(corners.astype(np.float32)).reshape(-1, 2)
    shift = 8
    mask = np.zeros(shape, np.uint8)
    cv2.fillConvexPoly(mask, np.round(hull * (1 << shift)).astype(np.int32), 1,
                       lineType=cv2.LINE_8, shift=shift)
    return mask.astype(bool)


def board_coords(rays, R, t):
    """Board-plane coordinates (u, v) [m] of the pixel rays' intersection with the PnP plane,
    and the PnP depth z_pnp [m] along z for each ray."""
    n = R[:, 2]
    d = float(n @ t)
    r3 = np.concatenate([rays, np.ones(rays.shape[:-1] + (1,))], axis=-1)
    zp = d / (r3 @ n)
    X = r3 * zp[..., None]
    B = (X - t) @ R                      # R^T (X - t)
    return B[..., 0], B[..., 1], zp


def square_index(u, v, board):
    """Square (i, j) of board coordinates, and whether the point is in the square's window."""
    fu, fv = u / board.square, v / board.square
    i, j = np.floor(fu).astype(int), np.floor(fv).astype(int)
    m = WINDOW_MARGIN
    win = (fu - i >= m) & (fu - i <= 1 - m) & (fv - j >= m) & (fv - j <= 1 - m)
    return i, j, win


# --------------------------------------------------------------------------------------------
# Measures.

def fit_plane_robust(P, r3, cls=None):
    """Robust plane of points P (n x 3, mm) seen along rays r3 (n x 3, z = 1): least squares
    Z = A + B X + C Y (well posed for a board facing the camera, whatever its dark/bright
    bias), refitted on the inliers. The outlier rule is applied within each class of `cls`
    (square colour), so that a dark/bright depth bias is kept as data, not cut as outliers.
    Returns (normal, d, residual along ray e [mm], residual along z [mm], inlier mask)."""
    cls = np.zeros(len(P), int) if cls is None else np.asarray(cls)
    inl = np.ones(len(P), bool)
    rn = np.linalg.norm(r3, axis=1)
    for _ in range(OUTLIER_ITERS):
        A = np.stack([np.ones(inl.sum()), P[inl, 0], P[inl, 1]], axis=1)
        (a0, b0, c0), *_ = np.linalg.lstsq(A, P[inl, 2], rcond=None)
        nrm = np.array([-b0, -c0, 1.0])
        zpl = a0 / (r3 @ nrm)
        ez = P[:, 2] - zpl
        e = ez * rn
        new = np.zeros(len(P), bool)
        for c in np.unique(cls):
            m = cls == c
            mi = m & inl
            if mi.sum() < 10:
                new |= m
                continue
            med = np.median(e[mi])
            mad = np.median(np.abs(e[mi] - med))
            new |= m & (np.abs(e - med) <= OUTLIER_K * 1.4826 * max(mad, 1e-9))
        if np.array_equal(new, inl):
            break
        inl = new
    scale = np.linalg.norm(nrm)
    return nrm / scale, a0 / scale, e, ez, inl


def _pair_corr(img, label=None):
    """Neighbour correlation sum(ab)/sqrt(sum a^2 sum b^2) over horizontal and vertical pairs
    where both are finite (and share a label when one is given). Returns (corr, n pairs)."""
    sa = sb = sab = 0.0
    n = 0
    for a, b, la, lb in ((img[:, :-1], img[:, 1:], None if label is None else label[:, :-1],
                          None if label is None else label[:, 1:]),
                         (img[:-1], img[1:], None if label is None else label[:-1],
                          None if label is None else label[1:])):
        ok = np.isfinite(a) & np.isfinite(b)
        if label is not None:
            ok &= la == lb
        x, y = a[ok], b[ok]
        sa += float(x @ x)
        sb += float(y @ y)
        sab += float(x @ y)
        n += int(ok.sum())
    if n == 0 or sa <= 0 or sb <= 0:
        return float("nan"), 0
    return sab / math.sqrt(sa * sb), n


PATTERN_CELL_PX = 16     # pixel-fixed pattern: cells of this many pixels square
PATTERN_MIN_PIXELS = 5   # a cell counts in a frame with at least this many inlier pixels
PATTERN_MIN_FRAMES = 5   # and in the pattern with at least this many frames


def pixel_cell_means(e, ys, xs, dark, shape, cell=PATTERN_CELL_PX):
    """Mean residual per image cell of cell x cell pixels, each colour's median removed first
    (so that the dark/bright bias is not a pattern): {(row, col): mean [mm]} for cells with at
    least PATTERN_MIN_PIXELS pixels."""
    e = np.asarray(e, float).copy()
    for c in (True, False):
        m = dark == c
        if m.any():
            e[m] -= np.median(e[m])
    ncol = shape[1] // cell + 1
    key = (ys // cell) * ncol + xs // cell
    cnt = np.bincount(key)
    sm = np.bincount(key, weights=e)
    return {(int(k) // ncol, int(k) % ncol): float(sm[k] / cnt[k])
            for k in np.nonzero(cnt >= PATTERN_MIN_PIXELS)[0]}


def pixel_pattern(results):
    """The part of the plane residual fixed to the pixel grid: per cell, the mean over frames of
    (cell mean - that frame's mean over its cells), for cells seen in PATTERN_MIN_FRAMES frames.
    Returns (std over cells of that pattern [mm], std of all frame cell values [mm], cells)."""
    per = {}
    allv = []
    for r in results:
        cells = r.get("pixel_cells") or {}
        if not cells:
            continue
        mu = np.mean(list(cells.values()))
        for k, v in cells.items():
            per.setdefault(k, []).append(v - mu)
            allv.append(v - mu)
    means = [np.mean(v) for v in per.values() if len(v) >= PATTERN_MIN_FRAMES]
    if len(means) < 2:
        return float("nan"), float("nan"), 0
    return float(np.std(means)), float(np.std(allv)), len(means)


def measure_frame(depth_mm, K, dist, corners, board=None, dark_parity=0):
    """Every per-frame measure of the table for one depth image (uint16 mm, 0 = invalid).

    depth_mm: h x w depth along z [mm]; K, dist: intrinsics of that image (raw pixels);
    corners: the board's inner corners in those raw pixels, row-major (board.cols per row);
    dark_parity: squares with (i + j) % 2 == dark_parity are dark.
    Returns a dict (see PROCEDURE for the definitions)."""
    board = board or Board()
    corners = np.asarray(corners, np.float64).reshape(-1, 2)
    check_corner_order(corners, board)
    R, t, reproj = board_pose(corners, K, dist, board)
    shape = depth_mm.shape
    rays = pixel_rays(shape, K, dist)
    mask = hull_mask(shape, corners)
    z_all = depth_mm.astype(np.float64)
    u, v, zp = board_coords(rays, R, t)
    si, sj, win = square_index(u, v, board)
    dark = ((si + sj) % 2) == dark_parity
    centre = R @ board.centre() + t
    normal = R[:, 2]
    incidence = math.degrees(math.acos(min(1.0, abs(normal @ centre) / np.linalg.norm(centre))))
    out = dict(dist_m=float(centre[2]), incidence_deg=incidence, reproj_px=reproj,
               hull_pixels=int(mask.sum()), R=R, t=t)

    # Invalid fractions (all window pixels, before any fit).
    wmask = mask & win
    valid = z_all > 0
    nb, nd = int((wmask & ~dark).sum()), int((wmask & dark).sum())
    out["inv_bright"] = float((wmask & ~dark & ~valid).sum()) / nb if nb else float("nan")
    out["inv_dark"] = float((wmask & dark & ~valid).sum()) / nd if nd else float("nan")
    out["inv_hull"] = float((mask & ~valid).sum()) / max(1, int(mask.sum()))

    # Plane fit on the valid hull pixels.
    sel = mask & valid
    ys, xs = np.nonzero(sel)
    r3 = np.concatenate([rays[ys, xs], np.ones((len(ys), 1))], axis=1)
    z = z_all[ys, xs]
    P = r3 * z[:, None]
    if len(z) < 50:
        out.update(dict(resid_std=float("nan"), resid_std_z=float("nan"), outliers=float("nan")))
        return _fill_nan(out)
    n_fit, d_fit, e, ez, inl = fit_plane_robust(P, r3, dark[ys, xs].astype(int))
    out["resid_std"] = float(np.std(e[inl], ddof=3))
    out["resid_std_z"] = float(np.std(ez[inl], ddof=3))
    out["outliers"] = float(1 - inl.mean())

    E = np.full(shape, np.nan)
    E[ys[inl], xs[inl]] = e[inl]
    out["pixel_cells"] = pixel_cell_means(e[inl], ys[inl], xs[inl], dark[ys[inl], xs[inl]], shape)
    out["corr_plane"], _ = _pair_corr(E)

    # Per-square windows.
    ncol = 1000
    lab = np.where(wmask & np.isfinite(E), (si + 100) * ncol + (sj + 100), -1)
    D = np.full(shape, np.nan)
    stats = {True: [0.0, 0, 0.0, 0], False: [0.0, 0, 0.0, 0]}   # ss, dof, sum e, n
    for L in np.unique(lab[lab >= 0]):
        m = lab == L
        vals = E[m]
        if vals.size < MIN_SQUARE_PIXELS:
            continue
        isdark = bool(dark[m][0])
        mu = vals.mean()
        D[m] = vals - mu
        s = stats[isdark]
        s[0] += float(((vals - mu) ** 2).sum())
        s[1] += vals.size - 1
        s[2] += float(vals.sum())
        s[3] += vals.size
    lab_ok = np.where(np.isfinite(D), lab, -1)
    out["corr_sq"], out["corr_pairs"] = _pair_corr(D, lab_ok)
    out["bright_sd"] = math.sqrt(stats[False][0] / stats[False][1]) if stats[False][1] else float("nan")
    out["dark_sd"] = math.sqrt(stats[True][0] / stats[True][1]) if stats[True][1] else float("nan")
    out["dark_bright_ratio"] = out["dark_sd"] / out["bright_sd"] if stats[False][1] else float("nan")
    if stats[True][3] and stats[False][3]:
        out["dark_minus_bright"] = stats[True][2] / stats[True][3] - stats[False][2] / stats[False][3]
    else:
        out["dark_minus_bright"] = float("nan")

    # Depth against the PnP plane (along z).
    diff = z - zp[ys, xs] * 1000.0
    g = np.abs(diff) <= PNP_GATE_MM
    out["pnp_offset"] = float(diff[g].mean()) if g.any() else float("nan")
    out["pnp_offset_median"] = float(np.median(diff[g])) if g.any() else float("nan")
    out["pnp_gate_frac"] = float(g.mean())
    out["pnp_sum"], out["pnp_n"] = float(diff[g].sum()), int(g.sum())   # for pixel-pooled means
    return out


def _fill_nan(out):
    for k in ("corr_plane", "corr_sq", "bright_sd", "dark_sd", "dark_bright_ratio",
              "dark_minus_bright", "pnp_offset", "pnp_offset_median", "pnp_gate_frac", "pnp_sum"):
        out.setdefault(k, float("nan"))
    out.setdefault("corr_pairs", 0)
    out.setdefault("pnp_n", 0)
    return out


def ir_square_amplitudes(ir, K, dist, corners, board=None):
    """Median IR amplitude over the windows of parity-0 squares and of parity-1 squares."""
    board = board or Board()
    R, t, _ = board_pose(np.asarray(corners, np.float64).reshape(-1, 2), K, dist, board)
    mask = hull_mask(ir.shape, corners)
    u, v, _ = board_coords(pixel_rays(ir.shape, K, dist), R, t)
    si, sj, win = square_index(u, v, board)
    par = (si + sj) % 2
    m = mask & win
    return (float(np.median(ir[m & (par == 0)])), float(np.median(ir[m & (par == 1)])))


def dark_parity_votes(frames, K, dist, board=None):
    """frames: iterable of (ir image, corners). Returns (votes for parity 0, votes for parity 1):
    a frame votes for the parity whose square windows are darker in its IR image."""
    votes = [0, 0]
    for ir, corners in frames:
        a0, a1 = ir_square_amplitudes(ir, K, dist, corners, board)
        votes[0 if a0 < a1 else 1] += 1
    return tuple(votes)


def repeat_groups(corner_sets, max_px=REPEAT_PX):
    """Groups (lists of indices, size >= 2) of frames whose corners all lie within max_px of
    each other's (single linkage on the max corner displacement)."""
    C = np.array([np.asarray(c).reshape(-1, 2) for c in corner_sets])
    n = len(C)
    parent = list(range(n))

    def find(a):
        while parent[a] != a:
            parent[a] = parent[parent[a]]
            a = parent[a]
        return a
    for a in range(n):
        dmax = np.abs(C[a + 1:] - C[a]).max(axis=(1, 2)) if a + 1 < n else np.array([])
        for b in np.nonzero(dmax <= max_px)[0] + a + 1:
            parent[find(b)] = find(a)
    groups = {}
    for a in range(n):
        groups.setdefault(find(a), []).append(a)
    return [g for g in groups.values() if len(g) >= 2]


def temporal_measures(depths, K, dist, corners, board=None, dark_parity=0):
    """Temporal spread over depth images of one repeated pose (corners: those of the first).
    Returns dict: temporal_sd [mm] (pooled per-pixel std, hull pixels valid in all frames),
    temporal_sd_bright / _dark (window pixels of bright / dark squares), temporal_corr
    (neighbour correlation of the first two frames' difference), pixels."""
    board = board or Board()
    corners = np.asarray(corners, np.float64).reshape(-1, 2)
    Z = np.array([d.astype(np.float64) for d in depths])
    mask = hull_mask(Z.shape[1:], corners) & np.all(Z > 0, axis=0)
    mean = Z.mean(axis=0)
    # Remove each frame's overall offset against the group mean (drift of the whole frame).
    Z = Z - np.array([np.median((z - mean)[mask]) for z in Z])[:, None, None]
    var = Z.var(axis=0, ddof=1)
    R, t, _ = board_pose(corners, K, dist, board)
    u, v, _ = board_coords(pixel_rays(Z.shape[1:], K, dist), R, t)
    si, sj, win = square_index(u, v, board)
    dark = ((si + sj) % 2) == dark_parity
    out = dict(temporal_sd=float(math.sqrt(var[mask].mean())), pixels=int(mask.sum()),
               frames=len(depths))
    mb, md = mask & win & ~dark, mask & win & dark
    out["temporal_sd_bright"] = float(math.sqrt(var[mb].mean())) if mb.any() else float("nan")
    out["temporal_sd_dark"] = float(math.sqrt(var[md].mean())) if md.any() else float("nan")
    diff = np.where(mask, Z[1] - Z[0], np.nan)
    diff -= np.nanmean(diff)
    out["temporal_corr"], _ = _pair_corr(diff)
    return out


# --------------------------------------------------------------------------------------------
# Binning.

TABLE_COLUMNS = [
    # key, header, format, scale
    ("resid_std", "plane sd", "{:.2f}", 1),
    ("bright_sd", "bright sd", "{:.2f}", 1),
    ("dark_sd", "dark sd", "{:.2f}", 1),
    ("dark_bright_ratio", "dark/bri", "{:.2f}", 1),
    ("corr_sq", "corr sq", "{:.2f}", 1),
    ("corr_plane", "corr pl", "{:.2f}", 1),
    ("dark_minus_bright", "dark-bri", "{:+.2f}", 1),
    ("inv_bright", "inv bri%", "{:.1f}", 100),
    ("inv_dark", "inv dark%", "{:.1f}", 100),
    ("pnp_offset", "z-pnp", "{:+.1f}", 1),
]


def bin_of(dist_m, width=BIN_M):
    lo = math.floor(dist_m / width) * width
    return (round(lo, 3), round(lo + width, 3))


def bin_table(results, temporal=(), width=BIN_M):
    """results: list of per-frame dicts; temporal: list of (dist_m, temporal dict).
    Returns rows [(bin, n, {key: mean})] sorted by distance, temporal pooled per bin."""
    bins = {}
    for r in results:
        bins.setdefault(bin_of(r["dist_m"], width), []).append(r)
    tb = {}
    for d, t in temporal:
        tb.setdefault(bin_of(d, width), []).append(t)
    rows = []
    for b in sorted(set(bins) | set(tb)):
        rs = bins.get(b, [])
        agg = {}
        for key, _, _, _ in TABLE_COLUMNS:
            vals = np.array([r[key] for r in rs], float)
            vals = vals[np.isfinite(vals)]
            agg[key] = float(np.median(vals)) if vals.size else float("nan")
        ts = tb.get(b, [])
        if ts:
            w = np.array([t["pixels"] * (t["frames"] - 1) for t in ts], float)
            agg["temporal_sd"] = float(math.sqrt(np.sum(w * np.array([t["temporal_sd"] ** 2 for t in ts])) / w.sum()))
            agg["temporal_corr"] = float(np.mean([t["temporal_corr"] for t in ts]))
            agg["temporal_groups"] = len(ts)
        else:
            agg["temporal_sd"] = agg["temporal_corr"] = float("nan")
            agg["temporal_groups"] = 0
        rows.append((b, len(rs), agg))
    return rows


def format_table(rows, markdown=False):
    head = ["distance m", "n"] + [h for _, h, _, _ in TABLE_COLUMNS] + ["temp sd", "temp corr", "rep"]
    lines = []
    body = []
    for b, n, agg in rows:
        cells = [f"{b[0]:.2f}-{b[1]:.2f}", str(n)]
        for key, _, fmt, scale in TABLE_COLUMNS:
            v = agg[key]
            cells.append(fmt.format(v * scale) if np.isfinite(v) else "-")
        cells.append(f"{agg['temporal_sd']:.2f}" if np.isfinite(agg["temporal_sd"]) else "-")
        cells.append(f"{agg['temporal_corr']:.2f}" if np.isfinite(agg["temporal_corr"]) else "-")
        cells.append(str(agg["temporal_groups"]))
        body.append(cells)
    if markdown:
        lines.append("| " + " | ".join(head) + " |")
        lines.append("|" + "|".join("---" for _ in head) + "|")
        for c in body:
            lines.append("| " + " | ".join(c) + " |")
    else:
        widths = [max(len(h), *(len(c[i]) for c in body)) if body else len(h) for i, h in enumerate(head)]
        lines.append("  ".join(h.rjust(w) for h, w in zip(head, widths)))
        for c in body:
            lines.append("  ".join(x.rjust(w) for x, w in zip(c, widths)))
    return "\n".join(lines)


def offset_vs_range(results):
    """Least squares pnp_offset = a + b (dist - 1 m) over frames: (a [mm], b [mm/m], n)."""
    d = np.array([r["dist_m"] for r in results])
    o = np.array([r["pnp_offset"] for r in results])
    ok = np.isfinite(d) & np.isfinite(o)
    if ok.sum() < 2:
        return float("nan"), float("nan"), int(ok.sum())
    A = np.stack([np.ones(ok.sum()), d[ok] - 1.0], axis=1)
    (a, b), *_ = np.linalg.lstsq(A, o[ok], rcond=None)
    return float(a), float(b), int(ok.sum())


def fit_intrinsics(folder, names, K, dist, board=None):
    """IR intrinsics fitted jointly on the corners of frames `names` (cv2.calibrateCamera, 5
    distortion coefficients, starting from K, dist). Returns (rms reprojection [px], K, dist)."""
    board = board or Board()
    obj = board.object_points().astype(np.float32)
    pts = [read_corners(os.path.join(folder, n + "_ir_points.yaml")).astype(np.float32).reshape(-1, 1, 2)
           for n in names]
    shape = cv2.imread(os.path.join(folder, names[0] + "_depth.png"), cv2.IMREAD_UNCHANGED).shape
    rms, K2, d2, _, _ = cv2.calibrateCamera([obj] * len(pts), pts, (shape[1], shape[0]), K.copy(),
                                            np.asarray(dist, np.float64).reshape(1, -1).copy(),
                                            flags=cv2.CALIB_USE_INTRINSIC_GUESS)
    return float(rms), K2, d2.ravel()


def run_folder(folder, board=None, dark_parity=None, frames=None, repeat_px=REPEAT_PX, calib=None,
               intrinsics=None):
    """Measures every frame of a data folder (intrinsics from `calib`, default the folder's
    calib_ir.yaml, or `intrinsics` = (K, dist) when given). Returns dict with results, excluded,
    temporal, dark_parity, votes, names, K, dist."""
    board = board or Board()
    if intrinsics is not None:
        K, dist = intrinsics
    else:
        K, dist = read_intrinsics(calib or os.path.join(folder, "calib_ir.yaml"))
    names = frames if frames is not None else list_frames(folder)
    loaded = [load_frame(folder, n) for n in names]
    votes = dark_parity_votes([(ir, c) for _, c, ir in loaded if ir is not None], K, dist, board)
    if dark_parity is None:
        if votes == (0, 0):
            raise ValueError("no IR images to find the dark squares: give the dark parity")
        dark_parity = 0 if votes[0] >= votes[1] else 1
    results, excluded, kept = [], [], []
    for k, (name, (depth, corners, _)) in enumerate(zip(names, loaded)):
        r = measure_frame(depth, K, dist, corners, board, dark_parity)
        r["frame"] = name
        if r["reproj_px"] > MAX_REPROJ_PX:
            excluded.append((name, r["reproj_px"]))
            continue
        results.append(r)
        kept.append(k)
    temporal = []
    for g in repeat_groups([loaded[k][1] for k in kept], repeat_px):
        g = [kept[i] for i in g]
        t = temporal_measures([loaded[i][0] for i in g], K, dist, loaded[g[0]][1], board, dark_parity)
        t["frames_names"] = [names[i] for i in g]
        temporal.append((float(np.mean([results[kept.index(i)]["dist_m"] for i in g])), t))
    return dict(results=results, excluded=excluded, temporal=temporal, dark_parity=dark_parity, votes=votes,
                names=names, K=K, dist=dist)


def pooled_depth_shift(results):
    """The upstream depth calibration's figure, mean(z_pnp - z) over every gated hull pixel of
    every frame (pixel-pooled) [mm]: comparable with calib_depth.yaml's depthShift."""
    s = sum(r["pnp_sum"] for r in results if r.get("pnp_n"))
    n = sum(r["pnp_n"] for r in results if r.get("pnp_n"))
    return -s / n if n else float("nan")


def incidence_table(results, width_deg=10.0):
    """Medians of plane sd, dark sd, dark/bright ratio and dark-minus-bright by incidence bins."""
    rows = {}
    for r in results:
        lo = math.floor(r["incidence_deg"] / width_deg) * width_deg
        rows.setdefault(lo, []).append(r)
    out = []
    for lo in sorted(rows):
        rs = rows[lo]
        med = lambda k: float(np.nanmedian([x[k] for x in rs]))
        out.append(((lo, lo + width_deg), len(rs), med("resid_std"), med("dark_sd"),
                     med("dark_bright_ratio"), med("dark_minus_bright")))
    return out
