"""The board's silhouette against what lies behind it: mixed pixels and edge jitter.

The same code measures real Kinect v2 frames and the simulator's frames of the same poses
(scripts/sensor_check). Units: depth images in millimetres (uint16, 0 = invalid), image positions
in raw pixels, board geometry in metres, every returned measure in pixels, millimetres or a
fraction, as its key says.

EDGE_PROCEDURE (printed by scripts/sensor_check) is the definition of the measures.
"""
import math

import cv2
import numpy as np

import sensor_check_lib as lib

ON_BOARD_MM = 15.0       # a pixel is on the board when its depth is within this of the fitted plane
EDGE_INSET_M = 0.020     # a crossing starts this far inside the board's outline ...
EDGE_OUTSET_M = 0.040    # ... and ends this far outside it
CORNER_KEEP_M = 0.030    # crossings stay this far from the outline's corners
MIN_JUMP_MM = 100.0      # the background must lie at least this far behind the board
BACK_BAND = 0.1          # two pixels agree (a surface) within this fraction of their depth behind the board
MAX_TRANSITION_PX = 8    # the background must begin within this many pixels after the edge
MIN_SIDE_CROSSINGS = 15  # a side counts for the edge spread with at least this many crossings
OUTLINE_PCT = 1.0        # the outline: this percentile and its complement of the board pixels' coordinates

EDGE_PROCEDURE = """\
Edge procedure (the board's silhouette; this text defines every edge measure)
  1. Plane: the robust plane of step 4 above, on the hull pixels; every valid pixel's residual
     E along z (measured minus plane, + = farther). A pixel is on the board when |E| <= {on:g} mm;
     the board is the 4-connected set of on-board pixels that holds most of the hull.
  2. Outline: the board's pixels in board coordinates (step 2 above); the outline is the
     rectangle between the {pct:g} % and {pct_hi:g} % points of u and of v, found per frame.
  3. Crossings: for each side of the outline, one crossing per pixel of its length, at least
     {corner:g} mm from the outline's corners: the pixels met along the board-plane segment from
     {inset:g} mm inside the side to {outset:g} mm outside it, perpendicular to it (projected with the
     intrinsics and distortion), in order.
  4. Edge: the last on-board pixel before the first pixel that is not (off the plane or
     invalid); the edge position is where the segment leaves that pixel [px along the crossing].
     Background: the first two adjacent valid pixels after the edge, within {maxtr} pixels of it,
     whose E agree within {band:.0%} (or {on:g} mm); its depth is their mean. A crossing counts when
     its first 3 pixels are on the board and the background is at least {jump:g} mm behind it.
       mixed/cross   valid pixels between the edge and the background that lie between the
                     surfaces: {on:g} mm < E < (1 - {band:g}) x background, per crossing;
                     mixed share = crossings with one or more.
       invalid/cross invalid pixels in the same stretch, per crossing.
       mixed t       where a mixed pixel falls between the surfaces: E / background (0 = board).
       edge sd       per side, the spread [px] of the edge positions about a straight line fitted
                     to them along the side (sides with {minside} crossings or more, pooled:
                     sqrt(sum r^2 / sum (n - 2))).
  5. Temporal edge sd: at a repeated pose, the crossings of the first frame's outline in every
     frame; the per-crossing spread of the edge position across frames, pooled [px].
  6. By range: the frame's board-centre distance; by incidence: the board's incidence.
"""


def edge_procedure_text():
    return EDGE_PROCEDURE.format(on=ON_BOARD_MM, pct=OUTLINE_PCT, pct_hi=100 - OUTLINE_PCT,
                                 corner=CORNER_KEEP_M * 1000, maxtr=MAX_TRANSITION_PX, inset=EDGE_INSET_M * 1000,
                                 outset=EDGE_OUTSET_M * 1000, jump=MIN_JUMP_MM, band=BACK_BAND,
                                 minside=MIN_SIDE_CROSSINGS)


def _plane_residual(depth_mm, K, dist, corners, board):
    """The robust plane on the hull pixels; returns (R, t, E [mm, NaN where invalid], rays, on)."""
    R, t, _ = lib.board_pose(corners, K, dist, board)
    rays = lib.pixel_rays(depth_mm.shape, K, dist)
    z = depth_mm.astype(np.float64)
    hull = lib.hull_mask(depth_mm.shape, corners)
    ys, xs = np.nonzero(hull & (z > 0))
    if len(ys) < 50:
        raise ValueError("fewer than 50 valid pixels on the board")
    r3 = np.concatenate([rays[ys, xs], np.ones((len(ys), 1))], axis=1)
    nrm, d, _, _, _ = lib.fit_plane_robust(r3 * z[ys, xs, None], r3)
    R3 = np.concatenate([rays, np.ones(rays.shape[:2] + (1,))], axis=-1)
    zpl = d / (R3 @ nrm)
    E = np.where(z > 0, z - zpl, np.nan)
    on = np.abs(np.nan_to_num(E, nan=1e9)) <= ON_BOARD_MM
    n, lab = cv2.connectedComponents(on.astype(np.uint8), connectivity=4)
    counts = np.bincount(lab[hull & on].ravel(), minlength=n)
    counts[0] = 0
    board_px = lab == int(counts.argmax())
    return R, t, E, rays, board_px, hull


def _outline_of(u, v, board_px):
    """The outline (u0, u1, v0, v1) [m] of the board pixels' board coordinates (step 2)."""
    uu, vv = u[board_px], v[board_px]
    return (float(np.percentile(uu, OUTLINE_PCT)), float(np.percentile(uu, 100 - OUTLINE_PCT)),
            float(np.percentile(vv, OUTLINE_PCT)), float(np.percentile(vv, 100 - OUTLINE_PCT)))


def board_outline(depth_mm, K, dist, corners, board=None):
    """The board's outline in board coordinates (u0, u1, v0, v1) [m] from its on-plane pixels."""
    board = board or lib.Board()
    corners = np.asarray(corners, np.float64).reshape(-1, 2)
    R, t, E, rays, board_px, _ = _plane_residual(depth_mm, K, dist, corners, board)
    u, v, _ = lib.board_coords(rays, R, t)
    return _outline_of(u, v, board_px)


def crossings(outline, R, t, K, dist, shape, dist_m):
    """Every crossing of the outline's sides: list of (side, along [px], pixels [(y, x)],
    exits [px along the crossing where the segment leaves each pixel])."""
    u0, u1, v0, v1 = outline
    h, w = shape
    fx = K[0, 0]
    step_m = dist_m / fx                     # about one pixel on the board
    fine = step_m / 8
    s = np.arange(-EDGE_INSET_M, EDGE_OUTSET_M + fine / 2, fine)
    rvec, _ = cv2.Rodrigues(R)
    out = []
    sides = [("u0", (u0, None), (-1, 0), (v0, v1)), ("u1", (u1, None), (1, 0), (v0, v1)),
             ("v0", (None, v0), (0, -1), (u0, u1)), ("v1", (None, v1), (0, 1), (u0, u1))]
    for name, (fu, fv), (du, dv), (a0, a1) in sides:
        along = np.arange(a0 + CORNER_KEEP_M, a1 - CORNER_KEEP_M, step_m)
        if along.size == 0:
            continue
        # Board points of every crossing, (n_along, n_s, 3).
        if fu is not None:
            pu = fu + du * s[None, :] + 0 * along[:, None]
            pv = along[:, None] + 0 * s[None, :]
        else:
            pu = along[:, None] + 0 * s[None, :]
            pv = fv + dv * s[None, :] + 0 * along[:, None]
        P = np.stack([pu, pv, np.zeros_like(pu)], axis=-1).reshape(-1, 3)
        img, _ = cv2.projectPoints(P, rvec, t, K, np.asarray(dist, np.float64))
        img = img.reshape(len(along), len(s), 2)
        for k in range(len(along)):
            xy = img[k]
            px = np.floor(xy + 0.5).astype(int)
            if (px[:, 0] < 0).any() or (px[:, 1] < 0).any() or (px[:, 0] >= w).any() or (px[:, 1] >= h).any():
                continue
            arc = np.concatenate([[0.0], np.cumsum(np.linalg.norm(np.diff(xy, axis=0), axis=1))])
            change = np.nonzero(np.any(np.diff(px, axis=0) != 0, axis=1))[0]
            starts = np.concatenate([[0], change + 1])
            pixels = [(int(px[i, 1]), int(px[i, 0])) for i in starts]
            exits = [float(arc[i]) for i in change] + [float(arc[-1])]
            # A crossing whose pixel sequence revisits a pixel is degenerate (grazing view).
            if len(set(pixels)) != len(pixels):
                continue
            out.append((name, float(along[k] / step_m), pixels, exits))
    return out


def _edge_of(E, pixels, exits):
    """Edge of one crossing: (edge position [px], background [mm], mixed ts, invalid count) or
    None when the crossing does not count (see EDGE_PROCEDURE steps 3-4)."""
    vals = np.array([E[y, x] for y, x in pixels])
    on = np.abs(np.nan_to_num(vals, nan=1e9)) <= ON_BOARD_MM
    if len(vals) < 9 or not on[:3].all() or on.all():
        return None
    k = int(np.argmin(on)) - 1                       # the last on-board pixel
    # The background: the first two adjacent valid pixels after the edge that agree.
    j = None
    for i in range(k + 1, min(len(vals) - 1, k + 1 + MAX_TRANSITION_PX)):
        a, b = vals[i], vals[i + 1]
        if np.isfinite(a) and np.isfinite(b) and abs(a - b) <= max(ON_BOARD_MM, BACK_BAND * abs(a)):
            j = i
            break
    if j is None:
        return None
    back = 0.5 * float(vals[j] + vals[j + 1])
    if back < MIN_JUMP_MM:
        return None
    mixed, invalid = [], 0
    for val in vals[k + 1:j]:
        if not np.isfinite(val):
            invalid += 1
        elif ON_BOARD_MM < val < back * (1 - BACK_BAND):
            mixed.append(val / back)
    return exits[k], back, mixed, invalid


def _pooled_line_sd(groups):
    """Pooled spread about a line fitted per group: groups of (along, position) arrays."""
    ss, dof = 0.0, 0
    for a, p in groups:
        if len(a) < MIN_SIDE_CROSSINGS:
            continue
        c = np.polyfit(a, p, 1)
        r = p - np.polyval(c, a)
        ss += float(r @ r)
        dof += len(a) - 2
    return math.sqrt(ss / dof) if dof else float("nan")


def measure_edges(depth_mm, K, dist, corners, board=None, outline=None):
    """Every edge measure of one frame (see EDGE_PROCEDURE). outline: the outline to cross
    (default: this frame's own). Returns a dict; also 'edges' {(side, along): position} for the
    temporal measure."""
    board = board or lib.Board()
    corners = np.asarray(corners, np.float64).reshape(-1, 2)
    R, t, E, rays, board_px, _ = _plane_residual(depth_mm, K, dist, corners, board)
    if outline is None:
        u, v, _ = lib.board_coords(rays, R, t)
        outline = _outline_of(u, v, board_px)
    centre = R @ board.centre() + t
    cr = crossings(outline, R, t, K, dist, depth_mm.shape, float(centre[2]))
    sides, edges, mixed_t, backs = {}, {}, [], []
    n = with_mixed = n_mixed = n_invalid = 0
    for side, along, pixels, exits in cr:
        r = _edge_of(E, pixels, exits)
        if r is None:
            continue
        pos, back, mixed, invalid = r
        n += 1
        n_mixed += len(mixed)
        with_mixed += bool(mixed)
        n_invalid += invalid
        mixed_t += mixed
        backs.append(back)
        sides.setdefault(side, ([], []))
        sides[side][0].append(along)
        sides[side][1].append(pos)
        edges[(side, round(along))] = pos
    out = dict(edge_crossings=n, edge_sides=sum(1 for a, _ in sides.values() if len(a) >= MIN_SIDE_CROSSINGS),
               outline=tuple(float(x) for x in outline), edges=edges, mixed_t=mixed_t,
               edge_back_mm=float(np.median(backs)) if backs else float("nan"))
    if n:
        out["mixed_per_cross"] = n_mixed / n
        out["mixed_share"] = with_mixed / n
        out["invalid_per_cross"] = n_invalid / n
        out["mixed_t_median"] = float(np.median(mixed_t)) if mixed_t else float("nan")
    else:
        out["mixed_per_cross"] = out["mixed_share"] = out["invalid_per_cross"] = float("nan")
        out["mixed_t_median"] = float("nan")
    out["edge_sd_px"] = _pooled_line_sd([(np.array(a), np.array(p)) for a, p in sides.values()])
    return out


def temporal_edges(depths, K, dist, corners, board=None):
    """Spread of the edge positions over the frames of one repeated pose: the outline and the
    crossings of the first frame, the per-crossing std across the frames, pooled [px]."""
    board = board or lib.Board()
    corners = np.asarray(corners, np.float64).reshape(-1, 2)
    outline = board_outline(depths[0], K, dist, corners, board)
    per = [measure_edges(d, K, dist, corners, board, outline)["edges"] for d in depths]
    common = set(per[0])
    for e in per[1:]:
        common &= set(e)
    if not common:
        return dict(temporal_edge_sd_px=float("nan"), temporal_edge_crossings=0)
    P = np.array([[e[c] for c in sorted(common)] for e in per])
    var = P.var(axis=0, ddof=1)
    return dict(temporal_edge_sd_px=float(math.sqrt(var.mean())), temporal_edge_crossings=len(common))


# --------------------------------------------------------------------------------------------
# A recording's edges, binned, and the simulator against them.

EDGE_COLUMNS = [
    # key, header, format
    ("mixed_share", "mixed share", "{:.2f}"),
    ("mixed_per_cross", "mixed/cross", "{:.2f}"),
    ("invalid_per_cross", "invalid/cross", "{:.2f}"),
    ("edge_sd_px", "edge sd px", "{:.2f}"),
    ("edge_back_mm", "back mm", "{:.0f}"),
]

# Targets of the comparison: sim/real within this band for every measure (as for the others).
RATIO_BAND = (0.8, 1.25)
MIN_BIN_FRAMES = 10      # a bin counts toward the targets with at least this many frames


def add_edges(load, results, temporal, K, dist, board=None):
    """Adds the edge measures to every per-frame result and the temporal edge spread to every
    repeated-pose group. load(name) gives a frame's (depth image, corners)."""
    board = board or lib.Board()
    for r in results:
        depth, corners = load(r["frame"])
        m = measure_edges(depth, K, dist, corners, board)
        m.pop("edges")
        r.update(m)
    for _, t in temporal:
        frames = [load(n) for n in t["frames_names"]]
        t.update(temporal_edges([d for d, _ in frames], K, dist, frames[0][1], board))


def margin_reflectivity_ratio(frames, K, dist, board=None, dark_parity=1, clip_dn=60000):
    """The board margin's IR amplitude over its bright squares': frames are (depth, corners, ir)
    (ir None: skipped; bright squares at or above clip_dn: skipped as clipped). Margin pixels:
    inside the frame's outline less 5 mm, outside the printed squares by 5 mm. Returns
    (median, 10th, 90th percentile, frames)."""
    board = board or lib.Board()
    ratios, g, s = [], 0.005, board.square
    for depth, corners, ir in frames:
        if ir is None:
            continue
        corners = np.asarray(corners, np.float64).reshape(-1, 2)
        R, t, _, rays, board_px, hull = _plane_residual(depth, K, dist, corners, board)
        u, v, _ = lib.board_coords(rays, R, t)
        u0, u1, v0, v1 = _outline_of(u, v, board_px)
        inner = (u > u0 + g) & (u < u1 - g) & (v > v0 + g) & (v < v1 - g)
        squares = (u > -s - g) & (u < board.cols * s + g) & (v > -s - g) & (v < board.rows * s + g)
        si, sj, win = lib.square_index(u, v, board)
        bright = hull & win & ((si + sj) % 2 != dark_parity)
        margin = inner & ~squares
        if not bright.any() or not margin.any():
            continue
        mb = float(np.median(ir[bright]))
        if mb < clip_dn:
            ratios.append(float(np.median(ir[margin])) / mb)
    if not ratios:
        return float("nan"), float("nan"), float("nan"), 0
    return (float(np.median(ratios)), float(np.percentile(ratios, 10)), float(np.percentile(ratios, 90)),
            len(ratios))


def edge_bin_table(results, temporal=(), width=lib.BIN_M):
    """Rows (bin, n frames with crossings, crossings, {key: median over frames}, mixed t quartiles,
    temporal edge sd) by distance bin."""
    bins, tb = {}, {}
    for r in results:
        if r.get("edge_crossings"):
            bins.setdefault(lib.bin_of(r["dist_m"], width), []).append(r)
    for d, t in temporal:
        tb.setdefault(lib.bin_of(d, width), []).append(t)
    rows = []
    for b in sorted(set(bins) | set(tb)):
        rs = bins.get(b, [])
        agg = {}
        for key, _, _ in EDGE_COLUMNS:
            vals = np.array([r[key] for r in rs], float)
            vals = vals[np.isfinite(vals)]
            agg[key] = float(np.median(vals)) if vals.size else float("nan")
        ts = np.concatenate([r["mixed_t"] for r in rs]) if rs else np.array([])
        agg["mixed_t"] = tuple(np.percentile(ts, [25, 50, 75])) if ts.size >= 5 else (float("nan"),) * 3
        tl = [t for t in tb.get(b, []) if t.get("temporal_edge_crossings")]
        agg["temporal_edge_sd_px"] = (float(np.sqrt(np.mean([t["temporal_edge_sd_px"] ** 2 for t in tl])))
                                      if tl else float("nan"))
        rows.append((b, len(rs), sum(r["edge_crossings"] for r in rs), agg))
    return rows


def format_edge_table(rows, markdown=False):
    head = (["distance m", "n", "crossings"] + [h for _, h, _ in EDGE_COLUMNS]
            + ["mixed t q25/50/75", "temp edge sd px"])
    body = []
    for b, n, nc, agg in rows:
        cells = [f"{b[0]:.2f}-{b[1]:.2f}", str(n), str(nc)]
        for key, _, fmt in EDGE_COLUMNS:
            cells.append(fmt.format(agg[key]) if np.isfinite(agg[key]) else "-")
        q = agg["mixed_t"]
        cells.append("/".join(f"{x:.2f}" for x in q) if np.isfinite(q[1]) else "-")
        cells.append(f"{agg['temporal_edge_sd_px']:.2f}" if np.isfinite(agg["temporal_edge_sd_px"]) else "-")
        body.append(cells)
    return _format(head, body, markdown)


def _format(head, body, markdown):
    if markdown:
        lines = ["| " + " | ".join(head) + " |", "|" + "|".join("---" for _ in head) + "|"]
        return "\n".join(lines + ["| " + " | ".join(c) + " |" for c in body])
    widths = [max([len(h)] + [len(c[i]) for c in body]) for i, h in enumerate(head)]
    return "\n".join(["  ".join(h.rjust(w) for h, w in zip(head, widths))]
                     + ["  ".join(x.rjust(w) for x, w in zip(c, widths)) for c in body])


def edge_incidence_table(results, width_deg=10.0):
    """Edge sd and mixed share by the board's incidence: [((lo, hi), n, edge sd, mixed share)]."""
    groups = {}
    for r in results:
        if r.get("edge_crossings"):
            lo = math.floor(r["incidence_deg"] / width_deg) * width_deg
            groups.setdefault(lo, []).append(r)
    out = []
    for lo in sorted(groups):
        rs = groups[lo]
        sd = np.array([r["edge_sd_px"] for r in rs], float)
        sh = np.array([r["mixed_share"] for r in rs], float)
        out.append(((lo, lo + width_deg), len(rs),
                    float(np.median(sd[np.isfinite(sd)])) if np.isfinite(sd).any() else float("nan"),
                    float(np.median(sh[np.isfinite(sh)])) if np.isfinite(sh).any() else float("nan")))
    return out


COMPARE = [("mixed_share", "mixed share"), ("mixed_per_cross", "mixed/cross"),
           ("invalid_per_cross", "invalid/cross"), ("edge_sd_px", "edge sd px"),
           ("mixed_t_median", "mixed t median"), ("temporal_edge_sd_px", "temp edge sd px")]


def compare_edges(real_rows, sim_rows):
    """Per bin and measure: (bin, n, label, real, sim, sim/real, ok); ok is None where the target
    does not apply (fewer than MIN_BIN_FRAMES frames, or a side without a value)."""
    sim = {b: agg for b, _, _, agg in sim_rows}
    out = []
    for b, n, _, agg in real_rows:
        s = sim.get(b, {})
        for key, label in COMPARE:
            if key == "mixed_t_median":
                rv, sv = agg["mixed_t"][1], s.get("mixed_t", (float("nan"),) * 3)[1]
            else:
                rv, sv = agg.get(key, float("nan")), s.get(key, float("nan"))
            if not (np.isfinite(rv) and np.isfinite(sv)) or rv == 0:
                out.append((b, n, label, rv, sv, float("nan"), None))
                continue
            val = sv / rv
            ok = RATIO_BAND[0] <= val <= RATIO_BAND[1]
            applies = n >= MIN_BIN_FRAMES or key == "temporal_edge_sd_px"
            out.append((b, n, label, rv, sv, val, ok if applies else None))
    return out


def format_edge_compare(rows, markdown=False):
    head = ["distance m", "n", "measure", "real", "sim", "sim/real", "target"]
    body = [[f"{b[0]:.2f}-{b[1]:.2f}", str(n), label,
             f"{rv:.2f}" if np.isfinite(rv) else "-", f"{sv:.2f}" if np.isfinite(sv) else "-",
             f"{val:.2f}" if np.isfinite(val) else "-", "-" if ok is None else ("ok" if ok else "MISS")]
            for b, n, label, rv, sv, val, ok in rows]
    return _format(head, body, markdown)


def measure_recording(folder, res, board=None):
    """Adds the edge measures to res (sensor_check_lib.run_folder's result) and the margin's
    reflectivity ratio (res['margin_ratio'], used by the simulated board). Returns the ratio's
    (median, p10, p90, frames)."""
    board = board or lib.Board()
    add_edges(lambda n: lib.load_frame(folder, n)[:2], res["results"], res["temporal"], res["K"], res["dist"], board)
    mr = margin_reflectivity_ratio([lib.load_frame(folder, r["frame"]) for r in res["results"]],
                                   res["K"], res["dist"], board, res["dark_parity"])
    res["margin_ratio"] = mr[0] if np.isfinite(mr[0]) else 1.0
    return mr


def real_report(res, margin, markdown=False, procedure=True):
    """The edge procedure (with `procedure`) and the recording's edge tables, as printed by
    sensor_check."""
    lines = [edge_procedure_text()] if procedure else []
    lines += ["Edges of the board (each cell: median over the bin's frames with a crossing; "
              "mixed t: quartiles of every mixed pixel in the bin):",
              format_edge_table(edge_bin_table(res["results"], res["temporal"]), markdown), "",
              "Edges by incidence (medians): incidence deg, n, edge sd px, mixed share"]
    for (lo, hi), n, sd, sh in edge_incidence_table(res["results"]):
        lines.append(f"  {lo:4.0f}-{hi:<4.0f} {n:3d}  {sd:6.2f}  {sh:6.2f}")
    if margin[3]:
        lines.append(f"Board margin's IR amplitude over the bright squares': {margin[0]:.2f} (10-90 % of {margin[3]} "
                     f"unclipped frames {margin[1]:.2f}-{margin[2]:.2f}); the simulated margin takes it")
    return "\n".join(lines)


def sim_report(res, sim_results, sim_temporal, markdown=False):
    """The simulated edge table and sim/real against the targets; returns (text, missed, checked)."""
    real_rows = edge_bin_table(res["results"], res["temporal"])
    sim_rows = edge_bin_table(sim_results, sim_temporal)
    rows = compare_edges(real_rows, sim_rows)
    checked = [r for r in rows if r[6] is not None]
    missed = [r for r in checked if not r[6]]
    lo, hi = RATIO_BAND
    text = "\n".join([
        "Simulated edges, same table:", format_edge_table(sim_rows, markdown), "",
        f"Edge targets: sim/real within {lo}-{hi} in every bin with at least {MIN_BIN_FRAMES} frames (the temporal",
        "edge sd wherever the recording repeats a pose). The simulated board stands before a plane parallel",
        "to it, as far behind as the real frame's edges found.",
        format_edge_compare(rows, markdown), "",
        f"Edge verdict: {len(checked) - len(missed)} of {len(checked)} targets met" + (
            "" if not missed else "; missed: " + ", ".join(f"{r[2]} at {r[0][0]:.2f}-{r[0][1]:.2f} m" for r in missed))])
    return text, len(missed), len(checked)
