"""A picture of one energy map as a gripper designer reads it (MODEL 6-8).

`plot_map(m, path)` draws, in world units with equal aspect:

- the energy `V` over `P_j` (viridis; infeasible points blank); points outside `P_j` greyed:
  eject as grey levels of `V`, vertex as tan-tinted grey levels, unreached flat light grey
  (both fingers fully closed there, so `V` is one value), with the boundary of `P_j` outlined;
- hatching where the part is in equilibrium, and the outline of the caged region;
- downhill trajectories by the map's own rule (kernels/trajectories.py: sliding, grid8, or
  continuous streamlines) from a sparse lattice of starting points of `P_j`;
- the end points of the trajectories that move (caged, tip prehension, ejection: the first point
  outside `P_j`, stalled), sized by how many points of `P_j` end there;
- the gripper to scale (palm, both fingers' links and joints, the part) in one
  representative pose: the caged end point contributing most to `Lambda`, else the stable point of
  lowest energy, else the point of `P_j` nearest its centroid.

Only the Agg canvas is used (no pyplot, no display, no global backend switch).
"""
from __future__ import annotations

import io
import math
from pathlib import Path

import numpy as np
from matplotlib import patheffects
from matplotlib.backends.backend_agg import FigureCanvasAgg
from matplotlib.collections import LineCollection
from matplotlib.figure import Figure
from matplotlib.lines import Line2D
from matplotlib.patches import Circle, FancyArrowPatch, Patch

from ..compute.layout import finger_arrays_of, hand_record, kernel_records
from ..kernels.streamline import max_streamline_steps, streamline_walk
from ..kernels.trajectories import (
    max_slide_points,
    new_memo,
    GOES_ON,
    successor,
)
from ..kernels.hand import finger_polyline
from ..kernels.meeting_search import no_slide_context
from ..model import (EJECT, END_CAGED, INFEASIBLE, REACHED, STREAMLINE_STEP, UNREACHED,
                     VERTEX_POINT)
from ..files import write_bytes_atomic

# How many trajectories to draw, roughly (starting points on a regular sub-lattice of the grid).
TARGET_TRAJECTORIES = 90

# Points outside P_j, drawn over the energy colour: (tint RGB, tint weight over the greyed
# energy, legend label). Weight 1 = flat colour.
OUTSIDE_STYLE = {
    UNREACHED: ((0.94, 0.94, 0.94), 1.0, "not reached: unreached (fingers close freely)"),
    EJECT: ((0.75, 0.75, 0.75), 0.0, "not reached: eject (a finger slips off), greyed V"),
    VERTEX_POINT: ((0.96, 0.72, 0.40), 0.45, "not reached: vertex strike, tinted V"),
}

# End-point markers: (marker, face colour, edge colour, legend label).
END_STYLE = {
    "caged": ("o", "#ff2d7a", "white", "caged end points"),
    "tip": ("D", "#ff9f1c", "black", "tip-prehension end points"),
    "ejection": ("X", "#e41a1c", "white", "ejection: first points outside P_j"),
    "stalled": ("s", "white", "black", "stalled: nothing lower to go to"),
}


# ---------------------------------------------------------------------------------------------
# Trajectories
# ---------------------------------------------------------------------------------------------
def sliding_points(start: int, m, stable: np.ndarray,
                   sliding: bool = True) -> tuple[np.ndarray, int]:
    """World points (n, 2) of the trajectory from `start` (kernels/trajectories.py, `successor`:
    the default rule, or grid8 without `sliding`): grid steps, and where every neighbour is
    uphill the slide on the true energy; and the flat index of the point where it ends (the
    map's `end_index`)."""

    energy = np.asarray(m.fields["energy"], dtype=np.float64)
    point_class = np.asarray(m.fields["point_class"])
    equilibrium = np.asarray(m.fields["equilibrium"], dtype=bool)
    fingers = finger_arrays_of(m.fields)
    x, y = np.asarray(m.x, float), np.asarray(m.y, float)
    ny, nx = energy.shape
    h = _grid_step(m)
    finger, solver, blocks = kernel_records(m.design, m.part, m.limits, m.accuracy, m.effects)
    hand = hand_record(m.design.w, m.command, h, finger, m.mu_left, m.mu_right)
    buf = np.empty((max_slide_points(ny, nx), 2))
    p = int(start)
    points = []
    for _ in range(energy.size):
        j, i = divmod(p, nx)
        points.append((x[i], y[j]))
        if point_class[j, i] != REACHED or stable[j, i]:
            break
        state, q, n = successor(energy, point_class, equilibrium, fingers, x, y, i, j, finger,
                                   solver, blocks, hand, sliding, buf, new_memo(0, False),
                                   no_slide_context())
        points.extend(map(tuple, buf[1:n]))
        p = int(q)
        if state != GOES_ON:
            break
    return np.array(points), p


def streamline_points(start: int, energy: np.ndarray, point_class: np.ndarray,
                      equilibrium: np.ndarray, caged: np.ndarray, x: np.ndarray,
                      y: np.ndarray) -> np.ndarray:
    """World points (n, 2) of the continuous trajectory from `start` (kernels/streamline.py, the
    rule the map's end points come from when it was computed with trajectory 'continuous')."""

    ny, nx = energy.shape
    steps = max_streamline_steps(ny, nx, STREAMLINE_STEP)
    path = np.empty((steps + 1, 2))
    j, i = divmod(int(start), nx)
    _, _, n = streamline_walk(energy, point_class, equilibrium, caged, i, j, STREAMLINE_STEP,
                              steps, np.full(energy.size, -1, dtype=np.int64), path)
    h = x[1] - x[0] if x.size > 1 else 1.0
    hy = y[1] - y[0] if y.size > 1 else h
    return np.column_stack([x[0] + path[:n, 0] * h, y[0] + path[:n, 1] * hy])


def sample_starts(reached: np.ndarray, moving: np.ndarray, target: int) -> np.ndarray:
    """Flat indices of a regular sub-lattice of the moving points of P_j (about `target`)."""
    n = int(np.count_nonzero(moving))
    if n == 0:
        return np.empty(0, dtype=np.int64)
    ny, nx = reached.shape
    jj, ii = np.nonzero(reached)
    k = max(1, int(round(math.sqrt(n / target))))
    # Centre the lattice on P_j, and keep it symmetric in x about the middle column.
    ci = nx // 2
    j0 = int(jj.min()) + k // 2
    on_lattice = np.zeros_like(reached)
    on_lattice[j0::k, :] = True
    cols = np.zeros(nx, dtype=bool)
    cols[ci % k::k] = True
    on_lattice &= cols[None, :]
    return np.flatnonzero((on_lattice & moving).ravel())


# ---------------------------------------------------------------------------------------------
# The picture
# ---------------------------------------------------------------------------------------------
def _cell_edges(v: np.ndarray, h: float) -> np.ndarray:
    if v.size == 1:
        return np.array([v[0] - 0.5 * h, v[0] + 0.5 * h])
    return np.concatenate([[v[0] - 0.5 * h], 0.5 * (v[1:] + v[:-1]), [v[-1] + 0.5 * h]])


def _grid_step(m) -> float:
    if m.x.size > 1:
        return float(m.x[1] - m.x[0])
    if m.y.size > 1:
        return float(m.y[1] - m.y[0])
    return float(m.grid.h)


def representative_point(m, stable, caged, end_count) -> tuple[int, str]:
    """Flat index of the pose to draw the gripper in, and why it was chosen (or -1)."""
    energy = m.fields["energy"]
    score = m.fields["caging_score"]
    ny, nx = energy.shape
    contribution = np.where(caged.ravel(), end_count * score.ravel(), -1.0)
    if caged.any() and contribution.max() > 0:
        return int(np.argmax(contribution)), "caged end point contributing most to Λ"
    if caged.any():
        return int(np.argmax(np.where(caged.ravel(), score.ravel(), -1.0))), \
            "best-scoring caged point"
    if stable.any():
        e = np.where(stable, energy, np.inf).ravel()
        return int(np.argmin(e)), "stable point of lowest energy"
    reached = m.fields["point_class"] == REACHED
    pool = reached if reached.any() else m.fields["point_class"] != INFEASIBLE
    if not pool.any():
        return -1, ""
    jj, ii = np.nonzero(pool)
    X, Y = np.meshgrid(m.x, m.y)
    cx, cy = X[pool].mean(), Y[pool].mean()
    k = int(np.argmin((X[pool] - cx) ** 2 + (Y[pool] - cy) ** 2))
    return int(jj[k] * nx + ii[k]), ("centre of P_j" if reached.any() else "centre of the map")


FINGER_COLOURS = ("#1f4e9c", "#b2182b")  # left, right


def gripper_pose(m, p: int) -> dict:
    """World geometry of the gripper with the part at grid point p: palm, fingers, part."""
    d = m.design
    nx = m.x.size
    j, i = divmod(p, nx)
    x, y = float(m.x[i]), float(m.y[j])
    fingers = []
    for side in (0, 1):
        t1 = float(m.fields["theta1"][side, j, i])
        t2 = float(m.fields["theta2"][side, j, i])
        if math.isfinite(t1) and math.isfinite(t2):
            jx, jy, bx, by, tx, ty = finger_polyline(side, t1, t2, d.l1, d.l2, d.w)
            fingers.append((side, np.array([[jx, jy], [bx, by], [tx, ty]])))
    xs = [-0.5 * d.w, 0.5 * d.w, x - m.part.r, x + m.part.r]
    ys = [0.0, y - m.part.r, y + m.part.r]
    for _, pts in fingers:
        xs += list(pts[:, 0])
        ys += list(pts[:, 1])
    return dict(x=x, y=y, fingers=fingers, box=(min(xs), max(xs), min(ys), max(ys)))


def _draw_gripper(ax, m, pose: dict, gid: str | None = None) -> None:
    """Palm, both fingers (links and joints) and the part, to scale; `gid` names the palm's and
    the fingers' lines (a figure that draws several grippers tells them apart by it)."""
    d = m.design
    halo = [patheffects.withStroke(linewidth=6.5, foreground="white")]
    z = 6
    ax.plot([-0.5 * d.w, 0.5 * d.w], [0.0, 0.0], color="#222222", lw=5, solid_capstyle="butt",
            zorder=z, path_effects=halo, gid=None if gid is None else f"{gid}:palm")
    for side, pts in pose["fingers"]:
        colour = FINGER_COLOURS[side]
        ax.plot(pts[:, 0], pts[:, 1], color=colour, lw=3.2, solid_joinstyle="round",
                solid_capstyle="round", zorder=z + 1, path_effects=halo,
                gid=None if gid is None else f"{gid}:finger")
        ax.plot(pts[:2, 0], pts[:2, 1], ls="none", marker="o", ms=5.5, mfc="white", mec=colour,
                mew=1.5, zorder=z + 2)
        ax.plot(pts[2:, 0], pts[2:, 1], ls="none", marker="o", ms=3.5, color=colour,
                zorder=z + 2)
    x, y = pose["x"], pose["y"]
    ax.add_patch(Circle((x, y), m.part.r, facecolor=(1, 1, 1, 0.25), edgecolor="black",
                        lw=1.8, zorder=z))
    ax.plot([x], [y], marker="+", ms=9, mew=2.0, color="black", zorder=z + 3)


#: A second gripper drawn over a map (`draw_map_panel`'s `others`): its colour and line style.
OTHER_GRIPPER_COLOUR = "#ff9f1c"


def pose_at(m, x: float, y: float) -> dict | None:
    """The gripper pose of map `m` with the part at (x, y), if that is one of m's grid points
    (maps of one part and spacing share the lattice x = i h, y = r + j h), else None."""
    h = _grid_step(m)
    i = int(round((x - float(m.x[0])) / h))
    j = int(round((y - float(m.y[0])) / h))
    if not (0 <= i < m.x.size and 0 <= j < m.y.size):
        return None
    if abs(float(m.x[i]) - x) > 1e-6 * h or abs(float(m.y[j]) - y) > 1e-6 * h:
        return None
    return gripper_pose(m, j * m.x.size + i)


def _draw_other_gripper(ax, m, pose: dict, gid: str, part: bool) -> None:
    """Another design's palm and fingers over a map, thinner and dashed in one colour; with
    `part`, also the part where the pose puts it (dashed: not the map's own pose)."""
    d = m.design
    z = 8
    ax.plot([-0.5 * d.w, 0.5 * d.w], [0.0, 0.0], color=OTHER_GRIPPER_COLOUR, lw=2.2, ls="--",
            zorder=z, gid=f"{gid}:palm")
    for _, pts in pose["fingers"]:
        ax.plot(pts[:, 0], pts[:, 1], color=OTHER_GRIPPER_COLOUR, lw=2.0, ls="--", marker="o",
                ms=3.0, zorder=z + 1, gid=f"{gid}:finger")
    if part:
        ax.add_patch(Circle((pose["x"], pose["y"]), m.part.r, facecolor="none",
                            edgecolor=OTHER_GRIPPER_COLOUR, lw=1.2, ls="--", zorder=z))


def _title(m) -> tuple[str, str]:
    """Title line (design, part, command) and a two-line subtitle (score and counts)."""
    d, pt, c, a = m.design, m.part, m.command, m.attrs
    g = lambda v: f"{v:g}"  # noqa: E731
    title = (f"Energy map   design l1={g(d.l1)} l2={g(d.l2)} r1={g(d.r1)} r2={g(d.r2)} "
             f"w={g(d.w)}   part r={g(pt.r)} μ={g(pt.mu)}{_finger_mu_text(m)}   command "
             f"F_left={g(c.f_left)} F_right={g(c.f_right)}")
    line1 = (f"Λ = {a.get('Lambda', float('nan')):.1f}    caging area Λh² = "
             f"{a.get('caging_area', float('nan')):.3f}    h = {g(_grid_step(m))}    "
             f"P_j = {a.get('n_reached', 0)} of {a.get('n_points', 0)} points")
    line2 = (f"trajectories from P_j end: caged {a.get('n_caged', 0)}, tip prehension "
             f"{a.get('n_tip_prehension', 0)}, ejection {a.get('n_ejection', 0)}, stalled "
             f"{a.get('n_stalled', 0)}")
    extra = []
    if a.get("n_caged_crossed"):
        extra.append(f"caged points with crossed fingers: {a['n_caged_crossed']} of "
                     f"{a.get('n_caged_points', 0)}")
    if a.get("n_tip_overlap"):
        extra.append(f"tip overlap: {a['n_tip_overlap']}")
    if str(a.get("window_edge", "")).startswith("user window"):
        extra.append("user window")
    if not m.effects.friction:
        extra.append("friction off")
    if extra:
        line1 += "    |    " + ", ".join(extra)
    return title, line1 + "\n" + line2


def _finger_mu_text(m) -> str:
    """The fingers' own friction where a map gives them one (MODEL 10, Scenario C), else ""."""
    if m.mu_left is None and m.mu_right is None:
        return ""
    left = m.part.mu if m.mu_left is None else m.mu_left
    right = m.part.mu if m.mu_right is None else m.mu_right
    return f" (fingers μ_L={left:g} μ_R={right:g}, palm μ)"


def _map_view(m) -> dict:
    """What a picture of map `m` needs before anything is drawn: the point sets, where every
    trajectory ends, the gripper's representative pose and the plot limits (the whole gripper
    is always inside them)."""
    energy = np.asarray(m.fields["energy"], dtype=np.float64)
    point_class = np.asarray(m.fields["point_class"])
    equilibrium = np.asarray(m.fields["equilibrium"], dtype=bool)
    end_state = np.asarray(m.fields["end_state"])
    ny, nx = energy.shape
    h = _grid_step(m)
    x, y = np.asarray(m.x, float), np.asarray(m.y, float)
    xe, ye = _cell_edges(x, h), _cell_edges(y, h)
    reached = point_class == REACHED
    stable = reached & equilibrium
    caged = stable & (end_state == END_CAGED)

    # Where every trajectory of P_j ends (computed by the kernels), a sparse subset drawn.
    ends = np.asarray(m.fields["end_index"]).ravel()
    start_mask = reached.ravel()
    end_count = np.bincount(ends[start_mask], minlength=ny * nx).astype(float)
    moving = reached & ~stable

    d = m.design
    p, why = representative_point(m, stable, caged, end_count)
    pose = gripper_pose(m, p) if p >= 0 else None
    xlo, xhi = min(xe[0], -0.5 * d.w), max(xe[-1], 0.5 * d.w)
    ylo, yhi = min(ye[0], 0.0), ye[-1]
    if pose is not None:
        bx0, bx1, by0, by1 = pose["box"]
        xlo, xhi, ylo, yhi = min(xlo, bx0), max(xhi, bx1), min(ylo, by0), max(yhi, by1)
    pad = 0.02 * max(xhi - xlo, yhi - ylo, 1e-9)
    limits = (xlo - pad, xhi + pad, ylo - pad, yhi + pad)
    return dict(energy=energy, point_class=point_class, ny=ny, nx=nx, h=h, x=x, y=y, xe=xe,
                ye=ye, reached=reached, stable=stable, caged=caged, ends=ends,
                end_count=end_count, moving=moving, pose=pose, why=why, limits=limits, map=m)


def _draw_layers(ax, m, v: dict, trajectories: bool = True, gid: str | None = None) -> tuple:
    """Draw map `m` (view `v` from `_map_view`) into `ax`: energy colour, greyed points outside
    P_j, equilibrium hatching, caged outline, the gripper to scale; with `trajectories`, also
    the downhill paths and their end points. Returns the energy mesh (for a colour bar) and the
    legend handles."""
    energy, point_class = v["energy"], v["point_class"]
    ny, nx, x, y, xe, ye = v["ny"], v["nx"], v["x"], v["y"], v["xe"], v["ye"]
    reached, stable, caged = v["reached"], v["stable"], v["caged"]
    pose, why = v["pose"], v["why"]
    d = m.design
    ax.set_facecolor("white")

    # Energy colour over every feasible point; the norm follows P_j when it exists.
    feasible = point_class != INFEASIBLE
    coloured = reached if reached.any() else feasible
    shown = np.ma.masked_where(~coloured | ~np.isfinite(energy), energy)
    ref = energy[coloured]
    ref = ref[np.isfinite(ref)]
    vmin, vmax = (float(ref.min()), float(ref.max())) if ref.size else (0.0, 1.0)
    if not vmax > vmin:
        vmin, vmax = vmin - 0.5, vmax + 0.5
    mesh = ax.pcolormesh(xe, ye, shown, cmap="viridis", vmin=vmin, vmax=vmax, shading="flat",
                         rasterized=True, zorder=0)
    handles = []
    # Outside P_j: greyed energy (eject, vertex: tinted) or a flat light grey (unreached, where
    # both fingers are fully closed and the energy is the same everywhere).
    lightness = 0.93 - 0.38 * np.clip((np.nan_to_num(energy, nan=vmax) - vmin) / (vmax - vmin),
                                      0.0, 1.0)
    grey = np.repeat(lightness[..., None], 3, axis=2)
    rgba_img = np.zeros((ny, nx, 4))
    for code, (tint, mix, label) in OUTSIDE_STYLE.items():
        mask = (point_class == code) & ~coloured
        if not mask.any():
            continue
        tint = np.asarray(tint, float)
        rgba_img[mask, :3] = (1.0 - mix) * grey[mask] + mix * tint
        rgba_img[mask, 3] = 1.0
        sample = (1.0 - mix) * 0.75 + mix * tint
        handles.append(Patch(facecolor=sample, edgecolor="0.5", lw=0.5,
                             label=f"{label}: {int(mask.sum())}"))
    if rgba_img[..., 3].any():
        ax.imshow(rgba_img, origin="lower", extent=(xe[0], xe[-1], ye[0], ye[-1]),
                  interpolation="nearest", aspect="auto", zorder=1)
    if (~feasible).any():
        handles.append(Patch(facecolor="white", edgecolor="0.5", lw=0.5,
                             label=f"infeasible (blank): {int((~feasible).sum())}"))
    if reached.any() and not reached.all() and ny > 1 and nx > 1:
        ax.contour(x, y, reached.astype(float), levels=[0.5], colors="black", linewidths=0.9,
                   zorder=2)
        handles.insert(0, Line2D([], [], color="black", lw=0.9,
                                 label=f"boundary of P_j (reached: {int(reached.sum())})"))

    # Equilibrium hatching and the caged region.
    if stable.any() and ny > 1 and nx > 1:
        cs = ax.contourf(x, y, stable.astype(float), levels=[0.5, 1.5], colors="none",
                         hatches=["////"], zorder=3)
        # Hatches take the edge colour (ContourSet is a Collection from matplotlib 3.8 on).
        for coll in ([cs] if hasattr(cs, "set_edgecolor") else cs.collections):
            coll.set_edgecolor((1.0, 1.0, 1.0, 0.85))
            coll.set_linewidth(0.0)
        handles.append(Patch(facecolor=(0.27, 0.0, 0.33), edgecolor="white", hatch="////",
                             label=f"part in equilibrium: {int(stable.sum())}"))
    if caged.any() and ny > 1 and nx > 1:
        ax.contour(x, y, caged.astype(float), levels=[0.5], colors="#ff2d7a", linewidths=1.6,
                   zorder=4)
        handles.append(Line2D([], [], color="#ff2d7a", lw=1.6,
                              label=f"caged region: {int(caged.sum())}"))

    if trajectories:
        handles += _draw_trajectories(ax, v)

    # The gripper to scale in one representative pose.
    if pose is not None:
        _draw_gripper(ax, m, pose, gid)
        handles.append(Line2D([], [], color=FINGER_COLOURS[1], lw=3.2,
                              label=f"gripper to scale, part at ({pose['x']:.2f}, "
                                    f"{pose['y']:.2f}): {why}"))
    else:
        ax.plot([-0.5 * d.w, 0.5 * d.w], [0, 0], color="#222222", lw=5)
    return mesh, handles


def _draw_trajectories(ax, v: dict) -> list:
    """Downhill trajectories from a sparse lattice of moving starts, and the end points of all
    moving trajectories of P_j sized by how many points end there; returns legend handles."""
    energy, point_class = v["energy"], v["point_class"]
    ny, nx, x, y = v["ny"], v["nx"], v["x"], v["y"]
    reached, stable, caged, moving = v["reached"], v["stable"], v["caged"], v["moving"]
    ends, end_count, m = v["ends"], v["end_count"], v["map"]
    starts = sample_starts(reached, moving, TARGET_TRAJECTORIES)
    handles = []
    flat_x = np.broadcast_to(x[None, :], (ny, nx)).ravel()
    flat_y = np.broadcast_to(y[:, None], (ny, nx)).ravel()
    segments = []
    arrows = []
    method = getattr(getattr(m, "accuracy", None), "trajectory", "grid8")
    for s in starts:
        if method == "continuous":
            pts = streamline_points(int(s), energy, point_class, m.fields["equilibrium"],
                                    np.asarray(m.fields["caging_score"]) > 0, x, y)
            path = pts
        else:
            pts, _ = sliding_points(int(s), m, stable, sliding=method == "sliding")
            path = pts
        if len(path) < 2:
            continue
        segments.append(pts)
        if len(path) >= 4:
            k = max(1, int(0.6 * (len(path) - 1)))
            arrows.append((pts[k - 1], pts[k]))
    if segments:
        stroke = [patheffects.withStroke(linewidth=2.4, foreground=(0, 0, 0, 0.55))]
        lc = LineCollection(segments, colors="white", linewidths=1.0, zorder=5,
                            capstyle="round", joinstyle="round")
        lc.set_path_effects(stroke)
        ax.add_collection(lc)
        for a, b in arrows:
            ax.add_patch(FancyArrowPatch(a, b, arrowstyle="-|>", mutation_scale=9,
                                         color="white", lw=0.8, zorder=5,
                                         path_effects=stroke, shrinkA=0, shrinkB=0))
        handles.append(Line2D([], [], color="white", lw=1.0, path_effects=stroke,
                              label=f"downhill trajectories ({len(segments)} of "
                                    f"{int(moving.sum())} moving starts)"))

    # End points of all trajectories of P_j, sized by the number of points ending there.
    # Marked: the ends of trajectories that move (a stable point is its own end: hatched only).
    end_points = np.unique(ends[moving.ravel()])
    kinds = {
        "caged": end_points[caged.ravel()[end_points]],
        "tip": end_points[(stable & ~caged).ravel()[end_points]],
        "ejection": end_points[~reached.ravel()[end_points]],
        "stalled": end_points[(moving.ravel()[end_points])],
    }
    cmax = float(end_count.max()) if end_count.size else 1.0
    for kind, idx in kinds.items():
        if idx.size == 0:
            continue
        marker, face, edge, label = END_STYLE[kind]
        size = 8.0 + 140.0 * np.sqrt(end_count[idx] / max(cmax, 1.0))
        ax.scatter(flat_x[idx], flat_y[idx], s=size, marker=marker, c=face, edgecolors=edge,
                   linewidths=0.7, zorder=7)
        handles.append(Line2D([], [], ls="none", marker=marker, ms=7, mfc=face, mec=edge,
                              label=f"{label}: {idx.size} (size ~ √points ending there)"))
    return handles


def draw_map(m) -> Figure:
    """The figure of one energy map (not saved)."""
    v = _map_view(m)
    xlo, xhi, ylo, yhi = v["limits"]
    aspect = (yhi - ylo) / max(xhi - xlo, 1e-9)
    # Inches: the axes at most 10.2 x 10, plus the colorbar (right), title and legend.
    axes_width = min(10.2, 10.0 / max(aspect, 1e-9))
    width = max(axes_width + 1.8, 10.0)
    height = max(axes_width * aspect, 2.5) + 2.2
    fig = Figure(figsize=(width, height), dpi=110, layout="constrained")
    FigureCanvasAgg(fig)
    ax = fig.add_subplot()
    mesh, handles = _draw_layers(ax, m, v, trajectories=True)

    ax.set_xlim(xlo, xhi)
    ax.set_ylim(ylo, yhi)
    ax.set_aspect("equal")
    ax.set_xlabel("part centre x")
    ax.set_ylabel("part centre y")
    cb = fig.colorbar(mesh, ax=ax, shrink=0.9, pad=0.01, aspect=30)
    cb.set_label("energy V (tension x length)")
    title, sub = _title(m)
    fig.suptitle(title + "\n" + sub, fontsize=10)
    ncol = 3 if len(handles) > 6 else 2
    fig.legend(handles=handles, loc="outside lower center", ncol=ncol, fontsize=8.5,
               frameon=True, facecolor="#f4f4f4")
    return fig


def draw_map_panel(ax, m, title: str | None = None, colorbar_label: str | None =
                   "energy V (unitless)", fontsize: float = 7.0, label: str | None = None,
                   others: tuple = (), at: int | None = None):
    """Draw map `m` into the given Axes as one panel of a larger figure: energy colour with its
    own colour bar, equilibrium hatching, caged outline and the gripper to scale at the
    representative pose (no trajectories). `others`: (map, label) pairs of other designs for
    the same part whose grippers are drawn over it (dashed, `OTHER_GRIPPER_COLOUR`) with the
    part where m's gripper holds it (their own representative pose where that is off their
    grid or infeasible for them); with them (or `label`), a legend names each gripper by its
    label, and the lines carry the label as their gid (`LABEL:palm`, `LABEL:finger`). `at`: the
    flat index of the grid point to draw the gripper at instead. Returns the energy mesh."""
    v = _map_view(m)
    if at is not None:
        v["pose"], v["why"] = gripper_pose(m, int(at)), "the part here"
        bx0, bx1, by0, by1 = v["pose"]["box"]
        xlo, xhi, ylo, yhi = v["limits"]
        v["limits"] = (min(xlo, bx0), max(xhi, bx1), min(ylo, by0), max(yhi, by1))
    mesh, _ = _draw_layers(ax, m, v, trajectories=False, gid=label)
    handles = []
    if label is not None and v["pose"] is not None:
        handles.append(Line2D([], [], color=FINGER_COLOURS[1], lw=3.2, label=label))
    boxes = [v["limits"]]      # the panel shows every gripper drawn whole
    for other, other_label in others:
        pose = None if v["pose"] is None else pose_at(other, v["pose"]["x"], v["pose"]["y"])
        own = pose is None or len(pose["fingers"]) < 2    # off its grid, or infeasible there
        if own:
            pose = _map_view(other)["pose"]
        if pose is None:
            continue
        _draw_other_gripper(ax, other, pose, other_label, part=own)
        boxes.append(pose["box"])
        handles.append(Line2D([], [], color=OTHER_GRIPPER_COLOUR, lw=2.0, ls="--",
                              label=other_label))
    if handles:
        ax.legend(handles=handles, loc="upper right", fontsize=fontsize, framealpha=0.85)
    b = np.array(boxes, float)
    xlo, xhi, ylo, yhi = b[:, 0].min(), b[:, 1].max(), b[:, 2].min(), b[:, 3].max()
    ax.set_xlim(xlo, xhi)
    ax.set_ylim(ylo, yhi)
    ax.set_aspect("equal")
    ax.tick_params(labelsize=fontsize)
    ax.set_xlabel("part centre x", fontsize=fontsize)
    ax.set_ylabel("part centre y", fontsize=fontsize)
    if colorbar_label is not None:
        cb = ax.figure.colorbar(mesh, ax=ax, shrink=0.85, pad=0.02, aspect=25)
        cb.set_label(colorbar_label, fontsize=fontsize)
        cb.ax.tick_params(labelsize=fontsize)
    if title:
        ax.set_title(title, fontsize=fontsize)
    return mesh


def plot_map(m, path) -> Path:
    """Write a PNG picture of map `m` to `path` atomically (`sweep.files.write_bytes_atomic`:
    rendered in memory, temporary name beside the target, fsync, rename; nothing left behind if
    anything fails)."""
    buffer = io.BytesIO()
    draw_map(m).savefig(buffer, format="png")
    return write_bytes_atomic(path, buffer.getbuffer())
