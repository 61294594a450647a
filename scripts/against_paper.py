#!/usr/bin/env python3
"""Against the paper: the counterfactuals behind docs/reproduction.md. Each subcommand changes one
thing the paper leaves open or models otherwise and prints (Markdown) whether the finding it
concerns (sweep/report/paper.py) then comes out as the paper says.

    findings        the report's table of findings for one or two stores
    palm            the best palm width of a part under each scene, reading, spacing, trajectory
    friction-trend  caging and tip-prehension end points against friction, by what is counted
    representatives the caging- and tip-focused designs' traits, by how they are chosen
    ratio-focus     the best caging design's R against tip-focused designs', part by part
    scenario-a      Scenario A's best gripper: grid spacing and where the cage score is taken
    scenario-b      Scenario B and its parameter usage per part, by reading

    .venv/bin/python scripts/against_paper.py findings results/paper.h5 results/paper-collision.h5
    .venv/bin/python scripts/against_paper.py palm results/paper.h5 --radius 0.4 --radius 0.8

Every map is computed by `compute_map` with the store's settings except the one changed; the
readings (what L_open is when the fingers cross, where the cage score is taken, what P_j holds)
are applied to the fields of the model's own maps, so they change nothing but the reading.
"""
from __future__ import annotations

import argparse
import dataclasses
import sys
import time
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent.parent))

from sweep.compute.maps import compute_map  # noqa: E402
from sweep.kernels.hand import finger_polyline, fingers_cross, mouth_opening  # noqa: E402
from sweep.kernels.hull import convex_hull, inscribed_radius  # noqa: E402
from sweep.model import (END_CAGED, END_TIP_PREHENSION, REACHED, Design, Grid,  # noqa: E402
                         Part)
from sweep.report import paper  # noqa: E402
from sweep.report.data import (CANDIDATE_DIMS, DESIGN_DIMS, candidate_metric_rows,  # noqa: E402
                               fmt, md_table, representative_designs, resolve_top_k)
from sweep.report.stores import open_store  # noqa: E402

CAGE_TOL = 1e-12   # CAGED needs L_open < 2r - CAGE_TOL (model-notes D5)
PALM_TOL = 1e-9    # palm contact (MODEL 7)
COINCIDE = 1e-12   # a force coincides with a hull vertex within this relative distance


def log(msg: str) -> None:
    print(msg, file=sys.stderr, flush=True)


# ---------------------------------------------------------------------------------------------
# A map of a store's scene with one thing changed
# ---------------------------------------------------------------------------------------------
def scene_map(scene, design: tuple, r: float, mu: float, h: float, effects=None, accuracy=None,
              forces: bool = False):
    """The map of `design` (l1, l2, r1, r2, w) for part (r, mu) with the scene's command,
    limits, accuracy and effects, at spacing h, with `effects` / `accuracy` replaced if given."""
    return compute_map(Design(*map(float, design)), Part(float(r), float(mu)),
                       scene.commands[0], Grid(h=float(h)), scene.limits,
                       accuracy or scene.accuracy, effects or scene.effects, forces=forces)


def r_classes(st) -> list[tuple[float, float, float]]:
    """(R, r1, r2) of every transmission ratio of the store, the first (r1, r2) in store order
    for each R (configurations depend on r1, r2 only through R: MODEL 11)."""
    seen = {}
    for r1 in st.ds["r1"].values:
        for r2 in st.ds["r2"].values:
            seen.setdefault(float(f"{r2 / r1:.9g}"), (float(r1), float(r2)))
    return sorted((R, *pair) for R, pair in seen.items())


# ---------------------------------------------------------------------------------------------
# Caging under the readings the paper leaves open
# ---------------------------------------------------------------------------------------------
def start_weights(m) -> np.ndarray:
    """Each start's share of the caging area (model-notes D36: the palm row counts half)."""
    w = np.ones(m.fields["end_state"].shape)
    w[0, :] = 0.5
    return w.ravel() * m.grid.h ** 2


def hand_at(m, flat: int):
    """Both fingers' polylines at the grid point of flat index `flat`."""
    d = m.design
    t1, t2 = m.fields["theta1"], m.fields["theta2"]
    j, i = np.unravel_index(flat, t1.shape[1:])
    return (finger_polyline(0, t1[0, j, i], t2[0, j, i], d.l1, d.l2, d.w),
            finger_polyline(1, t1[1, j, i], t2[1, j, i], d.l1, d.l2, d.w))


def caging_readings(m) -> dict:
    """The caging area of a map under each reading of MODEL 8 the paper leaves open, read off
    the map's own trajectories (a reading changes which end points are caged and their score,
    never where a trajectory goes: trajectories stop at every stable point):

    - `model`: MODEL 8 (L_open = 0 where the fingers cross; S of the end point);
    - `crossed_share`: the part of `model` from end points whose fingers cross;
    - `lopen_tips`: L_open of crossed fingers is their tip clearance (the least tip-to-tip and
      tip-to-finger distance, as for fingers that do not cross);
    - `crossed_not_caged`: an end point with crossed fingers is not a cage;
    - `score_at_start`: S taken at the start point (its own L_open, 0 if the mouth is wider
      than the part) for the starts whose trajectory ends caged."""
    f = m.fields
    r = m.part.r
    end_state, end = f["end_state"].ravel(), f["end_index"].ravel()
    weight = start_weights(m)
    caged = end_state == END_CAGED
    stable = caged | (end_state == END_TIP_PREHENSION)
    score = f["caging_score"].ravel()
    contained = f["contained"].ravel()
    crossed, tips = {}, {}
    for q in np.unique(end[stable]):
        left, right = hand_at(m, int(q))
        crossed[q] = bool(fingers_cross(left, right))
        tips[q] = float(mouth_opening(left, right, False))
    ends = end[stable]
    cross = np.array([crossed[q] for q in ends], dtype=bool)
    tip_score = np.array([1 - tips[q] / (2 * r) if contained[q] and tips[q] < 2 * r - CAGE_TOL
                          else 0.0 for q in ends])
    s_end = score[ends]
    out = dict(model=float(np.sum(s_end * weight[stable])),
               crossed_share=float(np.sum(np.where(cross, s_end, 0.0) * weight[stable])),
               lopen_tips=float(np.sum(np.where(cross, tip_score, s_end) * weight[stable])))
    out["crossed_not_caged"] = out["model"] - out["crossed_share"]
    start = np.clip(1 - f["l_open"].ravel() / (2 * r), 0.0, 1.0)
    out["score_at_start"] = float(np.sum(np.where(caged, np.nan_to_num(start), 0.0) * weight))
    return out


READINGS = {"lopen_tips": "L_open of crossed fingers = their tip clearance",
            "crossed_not_caged": "crossed fingers are no cage",
            "score_at_start": "S taken at the start point"}


@dataclasses.dataclass(frozen=True)
class Variant:
    """One way `palm` computes a design's maps: a label, its group (for --variant), the
    spacing, effects and accuracy, and whether the readings are applied to its maps."""
    label: str
    group: str
    h: float
    effects: object
    accuracy: object
    readings: bool = False


def palm_variants(scene, h: float, spacings, methods, reading_groups) -> list[Variant]:
    """Every map computation `palm` can make for a design, by group: the store's scene
    ("scene"), each effect it lacks ("finger_collision", "tip_contact", "both"), other spacings
    ("spacing") and trajectory methods ("trajectory"); the groups in `reading_groups` also get
    the readings; "paper-like": grid8 trajectories without step sampling on coarse grids, in
    the scene and with tip_contact."""
    eff, acc = scene.effects, scene.accuracy
    out = [Variant(f"the store's scene at h = {fmt(h)}", "scene", h, eff, acc)]
    for name in ("finger_collision", "tip_contact"):
        if not getattr(eff, name):
            out.append(Variant(f"+ {name}", name, h, dataclasses.replace(eff, **{name: True}),
                               acc))
    if not (eff.finger_collision or eff.tip_contact):
        out.append(Variant("+ tip_contact + finger_collision", "both", h,
                           dataclasses.replace(eff, finger_collision=True, tip_contact=True),
                           acc))
    out += [Variant(f"h = {fmt(s)}", "spacing", s, eff, acc) for s in spacings if s != h]
    for method in methods:
        if method == "no-sampling":
            out.append(Variant("steps not sampled (step_resolution 0)", "trajectory", h, eff,
                               dataclasses.replace(acc, step_resolution=0.0)))
        elif method != acc.trajectory:
            out.append(Variant(f"trajectory {method}", "trajectory", h, eff,
                               dataclasses.replace(acc, trajectory=method)))
    # the paper's numerics as they might have been: a coarse grid, steps from point to point
    # with nothing checked between them (no crease sliding, no step sampling)
    plain = dataclasses.replace(acc, trajectory="grid8", step_resolution=0.0)
    for s in PAPER_LIKE_SPACINGS:
        out.append(Variant(f"grid8, steps not sampled, h = {fmt(s)}", "paper-like", s, eff,
                           plain))
        if not eff.tip_contact:
            out.append(Variant(f"+ tip_contact, grid8, steps not sampled, h = {fmt(s)}",
                               "paper-like", s, dataclasses.replace(eff, tip_contact=True),
                               plain))
    return [dataclasses.replace(v, readings=v.group in reading_groups) for v in out]


PALM_GROUPS = ("scene", "finger_collision", "tip_contact", "both", "spacing", "trajectory",
               "paper-like")
#: Spacings of the paper-like numerics: the paper states none; 86,400 maps in 10 hours on 256
#: cores is about 107 core-seconds a map with a least-squares solve per point.
PAPER_LIKE_SPACINGS = (0.1, 0.05)


def best_per_width(scene, variant: Variant, chassis, classes, widths, r, mu) -> dict:
    """{label: {w: (largest caging area over the R classes, its R)}} for a variant's maps (and
    for each reading of them, labelled "variant, reading"); "_share" (when read): the part of
    the best design's area from end points whose fingers cross."""
    best = {variant.label: {w: (-1.0, None) for w in widths}}
    if variant.readings:
        best.update({f"{variant.label}, {text}": {w: (-1.0, None) for w in widths}
                     for text in READINGS.values()})
    shares = {}
    for w in widths:
        for R, r1, r2 in classes:
            m = scene_map(scene, (*chassis, r1, r2, w), r, mu, variant.h, variant.effects,
                          variant.accuracy)
            got = {variant.label: float(m.attrs["caging_area"])}
            if variant.readings:
                read = caging_readings(m)
                shares[(w, R)] = read["crossed_share"]
                got.update({f"{variant.label}, {text}": read[k] for k, text in READINGS.items()})
            for label, area in got.items():
                if area > best[label][w][0]:
                    best[label][w] = (area, R)
    if variant.readings:
        mine = best[variant.label]
        w = max(widths, key=lambda x: mine[x][0])
        best["_share"] = {variant.label: shares[(w, mine[w][1])] / mine[w][0]}
    return best


def cmd_palm(args) -> None:
    st = open_store(args.store)
    scene = st.scene
    chassis = (args.l1 or float(st.ds["l1"].values.max()),
               args.l2 or float(st.ds["l2"].values.max()))
    widths = [float(w) for w in st.ds["w"].values]
    classes = r_classes(st)
    variants = [v for v in palm_variants(scene, args.h, args.spacing, args.trajectory,
                                         args.readings_with) if v.group in args.variant]
    print(f"Best palm width per part over the chassis l1 = {fmt(chassis[0])}, l2 = "
          f"{fmt(chassis[1])} (every R of the store: {len(classes)} classes, x {len(widths)} "
          f"widths), store `{args.store}` ({st.attrs.get('effects_on')}); caging area (MODEL "
          "8's Lambda h^2, palm row at half a cell) of the best design at each w, and the "
          "paper's w's when the best is another; **bold**: the best w is the paper's.\n")
    rows, started = [], time.time()
    for r in args.radius:
        for mu in st.mu:
            cells = {"_share": {}}
            for v in variants:
                got = best_per_width(scene, v, chassis, classes, widths, r, mu)
                cells["_share"].update(got.pop("_share", {}))
                cells.update(got)
                log(f"palm: r = {r:g}, mu = {mu:g}: {v.label} ({time.time() - started:.0f} s)")
            rows.append((r, float(mu), cells))
    for r in args.radius:
        paper_w = paper.PAPER_PALM.get(r)
        mine = [row for row in rows if row[0] == r]
        header = ["variant"] + [f"r = {fmt(r)}, mu = {fmt(mu)}" for _, mu, _ in mine]
        table = []
        for label in (k for k in mine[0][2] if k != "_share"):
            line = {"variant": label}
            for (_, _mu, cells), col in zip(mine, header[1:]):
                best = cells[label]
                w = max(widths, key=lambda x: best[x][0])
                text = f"w = {fmt(w)} (R {fmt(best[w][1])}): {fmt(best[w][0])}"
                ours = paper_w is not None and any(abs(w - q) < 1e-9 for q in paper_w)
                if paper_w is not None and not ours:
                    text += "; " + ", ".join(f"w = {fmt(q)}: {fmt(best[q][0])}" for q in paper_w)
                line[col] = f"**{text}**" if ours else text
            table.append(line)
        print(md_table(table, header))
        for label in mine[0][2]["_share"]:
            print(f"\nShare of the best design's caging area ({label}) from end points whose "
                  "fingers cross: "
                  + "; ".join(f"mu = {fmt(mu)}: {fmt(100 * cells['_share'][label])} %"
                              for _, mu, cells in mine))
        print()
    log(f"palm: {time.time() - started:.0f} s")


# ---------------------------------------------------------------------------------------------
# Caging and tip prehension against friction
# ---------------------------------------------------------------------------------------------
def cmd_friction_trend(args) -> None:
    for path in args.stores:
        st = open_store(path)
        print(f"`{path}` ({st.attrs.get('effects_on')}): summed over the "
              f"{st.per_design('Lambda', 0, 0).size:,} designs, mu = "
              f"{', '.join(fmt(m) for m in st.mu)}\n")
        table = []
        for ri, r in enumerate(st.r):
            total = {k: [float(np.sum(st.per_design(k, ri, mi))) for mi in range(st.mu.size)]
                     for k in ("n_caged", "n_tip_prehension", "n_caged_points", "caging_area",
                               "n_reached", "n_eject", "n_equilibrium")}
            share = [c / (c + t) for c, t in zip(total["n_caged"], total["n_tip_prehension"])]
            for k, v in list(total.items()) + [("caged share of stable ends", share)]:
                table.append({"r": fmt(r), "count": k, **{f"mu = {fmt(m)}": fmt(x)
                                                          for m, x in zip(st.mu, v)},
                              "falls?": "yes" if v[-1] < v[0] else "no"})
        print(md_table(table, list(table[0])) + "\n")
    if args.tip_sample:
        sample_with_effect(args)


def sample_with_effect(args) -> None:
    """n_caged and n_tip_prehension summed over a random sample of designs, in the store's scene
    and with tip_contact, at every part."""
    st = open_store(args.stores[0])
    scene = st.scene
    rng = np.random.default_rng(args.seed)
    n = st.per_design("Lambda", 0, 0).size
    picks = rng.choice(n, size=min(args.tip_sample, n), replace=False)
    eff = dataclasses.replace(scene.effects, tip_contact=True)
    print(f"A sample of {picks.size} designs (seed {args.seed}) at h = {fmt(scene.h)}, in "
          f"`{args.stores[0]}`'s scene and with tip_contact; end points summed over the sample:\n")
    table, started = [], time.time()
    for r in st.r:
        sums = {k: np.zeros(st.mu.size) for k in ("model caged", "model tip", "tip_contact caged",
                                                  "tip_contact tip")}
        for mi, mu in enumerate(st.mu):
            for k in picks:
                d = st.design(int(k))
                design = tuple(d[x] for x in DESIGN_DIMS)
                for tag, effects in (("model", None), ("tip_contact", eff)):
                    m = scene_map(scene, design, r, mu, scene.h, effects)
                    sums[f"{tag} caged"][mi] += m.attrs["n_caged"]
                    sums[f"{tag} tip"][mi] += m.attrs["n_tip_prehension"]
        log(f"friction-trend sample: r = {r:g} ({time.time() - started:.0f} s)")
        for k, v in sums.items():
            table.append({"r": fmt(r), "end points": k, **{f"mu = {fmt(m)}": fmt(x)
                                                           for m, x in zip(st.mu, v)},
                          "falls?": "yes" if v[-1] < v[0] else "no"})
    print(md_table(table, list(table[0])) + "\n")


# ---------------------------------------------------------------------------------------------
# The representative designs
# ---------------------------------------------------------------------------------------------
def traits(st, idx) -> dict:
    """Mean R, l1, l2, w of the designs `idx` (flat, store order)."""
    ds = [st.design(int(k)) for k in np.atleast_1d(idx)]
    return {"R": np.mean([d["r2"] / d["r1"] for d in ds]),
            **{p: np.mean([d[p] for d in ds]) for p in ("l1", "l2", "w")}}


def cmd_representatives(args) -> None:
    r, mu = args.part
    for path in args.stores:
        st = open_store(path)
        ev = paper.Evidence(st)
        ri, mi = ev.part(r, mu)
        caged = st.per_design("n_caged", ri, mi).astype(float)
        tip = st.per_design("n_tip_prehension", ri, mi).astype(float)
        area = st.per_design("caging_area", ri, mi)
        stable = caged + tip
        share = np.where(stable > 0, caged / np.maximum(stable, 1), np.nan)
        n = max(1, int(round(args.fraction * caged.size)))
        with_ends = np.flatnonzero(stable > 0)
        by_share = with_ends[np.argsort(share[with_ends], kind="stable")]
        reps = representative_designs(caged, tip)
        choices = {
            "the report's rule: most caged vs most tip-prehension end points":
                ([reps["caging focused"]], [reps["tip focused"]]),
            f"top {args.fraction:.0%} by caged end points vs by tip-prehension end points":
                (np.argsort(-caged, kind="stable")[:n], np.argsort(-tip, kind="stable")[:n]),
            f"top {args.fraction:.0%} by caging area vs by tip-prehension end points":
                (np.argsort(-area, kind="stable")[:n], np.argsort(-tip, kind="stable")[:n]),
            f"top vs bottom {args.fraction:.0%} by caged share of stable end points":
                (by_share[::-1][:n], by_share[:n]),
        }
        print(f"`{path}` ({st.attrs.get('effects_on')}), part r = {fmt(r)}, mu = {fmt(mu)}: "
              "caging-focused against tip-focused designs (mean over the group)\n")
        table = []
        for label, (a, b) in choices.items():
            ta, tb = traits(st, a), traits(st, b)
            larger = [k for k in ta if ta[k] > tb[k] + 1e-9]
            table.append({"choice": label, **{k: f"{fmt(ta[k])} vs {fmt(tb[k])}" for k in ta},
                          "larger (of R, l1, l2, w)": ", ".join(larger) or "none"})
        print(md_table(table, list(table[0])) + "\n")


def cmd_ratio_focus(args) -> None:
    """Per part: the best caging design's R against the R of the tip-focused design, by how
    the tip-focused design is chosen."""
    for path in args.stores:
        st = open_store(path)
        ev = paper.Evidence(st)
        print(f"`{path}` ({st.attrs.get('effects_on')}): R of the best caging design against "
              "the R of tip-prehension-focused designs, part by part\n")
        table = []
        n = max(1, int(round(args.fraction * st.per_design("Lambda", 0, 0).size)))
        for p in st.parts():
            caged = st.per_design("n_caged", *p).astype(float)
            tip = st.per_design("n_tip_prehension", *p).astype(float)
            one = representative_designs(caged, tip)["tip focused"]
            stable = caged + tip
            share = np.where(stable > 0, tip / np.maximum(stable, 1), -1.0)
            groups = {"most tip ends (the report's)": [one],
                      f"top {args.fraction:.0%} by tip ends": np.argsort(-tip, kind="stable")[:n],
                      f"top {args.fraction:.0%} by tip share of stable ends":
                          np.argsort(-share, kind="stable")[:n]}
            best = ev.best(p)["R"]
            line = {"part": paper.part_name(st, p), "best caging R": fmt(best),
                    "tip ends of the most-tip design": int(tip[one])}
            for label, idx in groups.items():
                R = traits(st, idx)["R"]
                line[label] = f"{fmt(R)}" + (" (below)" if best > R + 1e-9 else "")
            table.append(line)
        print(md_table(table, list(table[0])))
        for label in list(table[0])[3:]:
            print(f"- {label}: the best caging R is above it at "
                  f"{sum('(below)' in row[label] for row in table)} of {len(table)} parts.")
        print()


# ---------------------------------------------------------------------------------------------
# The manipulation metric in plain Python, with its readings
# ---------------------------------------------------------------------------------------------
def counted_forces(m, scale: str, drop_tip_overlap: bool = False):
    """The counted poses of a map with forces (MODEL 10; model-notes D9, D17): lattice (i, j),
    the per-unit-tension resultants of the left and right fingers times the cage score, where
    the score is `scale`: "S_geo" (MODEL 10: the pose's own geometric cage score), "S_end" (the
    caging score of the end of the pose's trajectory, 0 unless it ends caged). With
    `drop_tip_overlap`, poses where a finger's distal link passed through the part are left out
    of P_j."""
    f = m.fields
    h, r, w = m.grid.h, m.part.r, m.design.w
    X, Y = np.meshgrid(m.x, m.y)
    palm = (np.abs(Y - r) <= PALM_TOL) & (np.abs(X) <= 0.5 * w + PALM_TOL)
    det = f["forces_determined"]
    s_geo = f["geometric_cage_score"]
    ok = ((f["point_class"] == REACHED) & ~f["equilibrium"] & ~palm & det[0] & det[1]
          & (s_geo > 0))
    if drop_tip_overlap:
        ok &= ~(f["tip_overlap"][0] | f["tip_overlap"][1])
    if scale == "S_geo":
        s = s_geo
    else:
        end, state = f["end_index"].ravel(), f["end_state"].ravel()
        s = np.where(state == END_CAGED, f["caging_score"].ravel()[np.maximum(end, 0)],
                     0.0).reshape(s_geo.shape)
        ok &= s > 0
    j, i = np.nonzero(ok)
    cols = np.rint(m.x[i] / h).astype(np.int64)
    rows = np.rint((m.y[j] - r) / h).astype(np.int64)
    fx, fy = f["resultant_force_x"], f["resultant_force_y"]
    k = s[j, i]
    return (rows, cols, fx[0, j, i] * k, fy[0, j, i] * k, fx[1, j, i] * k, fy[1, j, i] * k)


class Poses:
    """Forces gathered per pose of a part's lattice, each with its geometry's parameters."""

    def __init__(self):
        self.parts = []

    def add(self, rows, cols, fx, fy, params):
        n = rows.size
        self.parts.append((rows, cols, fx, fy, np.tile(params, (n, 1))))

    def groups(self):
        """(fx, fy, params) of every pose with a force, pose by pose."""
        if not self.parts:
            return
        rows, cols, fx, fy = (np.concatenate([p[k] for p in self.parts]) for k in range(4))
        params = np.concatenate([p[4] for p in self.parts])
        key = rows * 100_000 + cols
        order = np.argsort(key, kind="stable")
        key, fx, fy, params = key[order], fx[order], fy[order], params[order]
        cuts = np.flatnonzero(np.diff(key)) + 1
        for a, b in zip(np.r_[0, cuts], np.r_[cuts, key.size]):
            yield fx[a:b], fy[a:b], params[a:b]


def pose_value(fx, fy) -> tuple[float, np.ndarray]:
    """The radius of the largest origin-centred circle in the hull (0 unless the origin is
    strictly inside: MODEL 10) and which forces coincide with a hull vertex."""
    if fx.size < 3 or not ((fx < 0).any() and (fx > 0).any() and (fy < 0).any()
                           and (fy > 0).any()):
        return 0.0, np.zeros(fx.size, dtype=bool)
    hx, hy = convex_hull(np.ascontiguousarray(fx), np.ascontiguousarray(fy))
    value = float(inscribed_radius(hx, hy, hx.shape[0]))
    vertex = np.zeros(fx.size, dtype=bool)
    for vx, vy in zip(hx, hy):
        vertex |= np.hypot(fx - vx, fy - vy) <= COINCIDE * np.hypot(vx, vy)
    return value, vertex


def metric(poses: Poses, search: np.ndarray):
    """The metric (sum of pose values), the poses with a positive value, and the parameter
    usage by two readings: the range among the hull's vertex geometries (MODEL 10) and among
    every counted geometry of the pose; and the mean of each parameter's least vertex value,
    as a fraction of its search range from the lower bound."""
    total, n, vert, every, low = 0.0, 0, np.zeros(5), np.zeros(5), np.zeros(5)
    for fx, fy, params in poses.groups():
        value, vertex = pose_value(fx, fy)
        if value <= 0:
            continue
        total += value
        n += 1
        v = params[vertex]
        vert += (v.max(axis=0) - v.min(axis=0)) / search[:, 1]
        every += (params.max(axis=0) - params.min(axis=0)) / search[:, 1]
        low += (v.min(axis=0) - search[:, 0]) / search[:, 1]
    with np.errstate(invalid="ignore"):
        return total, n, vert / n, every / n, low / n


def search_ranges(st) -> np.ndarray:
    """(lower bound, range) of w, l1, l2, r1, r2 in the store (the parameter usage's order)."""
    return np.array([(float(st.ds[p].values.min()), float(np.ptp(st.ds[p].values)))
                     for p in ("w", "l1", "l2", "r1", "r2")])


def scenario_a(st, candidate: tuple, r: float, mu: float, h: float, scales) -> dict:
    """Scenario A's metric of a candidate (l1, l2, r1, r2) for one part in plain Python, for
    each cage score of `scales` (counted_forces), from one set of maps."""
    poses = {scale: Poses() for scale in scales}
    extremes = [float(v) for v in st.attrs["manipulation_scenario_a_computed_f_left"]]
    for w in st.ds["w"].values:
        m = scene_map(st.scene, (*candidate, float(w)), r, mu, h, forces=True)
        for scale in scales:
            rows, cols, lx, ly, rx, ry = counted_forces(m, scale)
            for f_left in extremes:
                poses[scale].add(rows, cols, f_left * lx + (2 - f_left) * rx,
                                 f_left * ly + (2 - f_left) * ry, np.array([float(w), *candidate]))
    search = search_ranges(st)
    return {scale: metric(poses[scale], search)[0] for scale in scales}


def cmd_scenario_a(args) -> None:
    st = open_store(args.store)
    top_k = resolve_top_k(st, None)
    rows = sorted(candidate_metric_rows(st, top_k, "a"), key=lambda c: -c["a_sum"])
    picks = [tuple(c[d] for d in CANDIDATE_DIMS) for c in rows[:args.top]]
    if args.paper_gripper not in picks:
        picks.append(args.paper_gripper)
    b = st.ds["manipulation_b"].transpose("r", "mu").values
    print(f"Scenario A, `{args.store}` ({st.attrs.get('effects_on')}): the store's {args.top} "
          "best candidates and the paper's gripper (l1, l2, r1, r2), recomputed in plain Python "
          "(its check: the column 'store' against the first), by spacing and by where the cage "
          "score is taken (S_geo: the pose's own, MODEL 10; S_end: the caging score of the end "
          "of the pose's trajectory). Summed over the "
          f"{st.r.size * st.mu.size} parts, in the store's units (values at spacing h times "
          f"(h / {fmt(st.scene.h)})^2: the metric sums per-pose values, so it grows as 1/h^2); "
          "B wins: the parts where the store's B exceeds the candidate's A (of those not both "
          "0), at the store's spacing.\n")
    table, per_part, started = [], [], time.time()
    for cand in picks:
        idx = tuple(int(np.flatnonzero(np.abs(st.ds[d].values - v) < 1e-9)[0])
                    for d, v in zip(CANDIDATE_DIMS, cand))
        stored = st.ds["manipulation_a"].transpose(*CANDIDATE_DIMS, "r", "mu").values[idx]
        line = {"candidate": ", ".join(fmt(v) for v in cand),
                "store": fmt(float(np.nansum(stored)))}
        for h in args.spacing:
            got = {(ri, mi): scenario_a(st, cand, r, mu, h, args.scale)
                   for ri, r in enumerate(st.r) for mi, mu in enumerate(st.mu)}
            for scale in args.scale:
                values = {p: v[scale] * (h / st.scene.h) ** 2 for p, v in got.items()}
                line[f"{scale}, h = {fmt(h)}"] = fmt(sum(values.values()))
                if h == st.scene.h:
                    rest = [p for p in values if not (values[p] == 0 and b[p] == 0)]
                    line[f"B wins ({scale})"] = (f"{sum(b[p] > values[p] for p in rest)} of "
                                                 f"{len(rest)}")
                per_part.append({"candidate": line["candidate"], "reading": scale,
                                 "h": fmt(h), **{f"{fmt(st.r[p[0]])}/{fmt(st.mu[p[1]])}":
                                                 fmt(v) for p, v in values.items()}})
            log(f"scenario-a: {cand} h = {h:g} ({time.time() - started:.0f} s)")
        table.append(line)
    print(md_table(table, list(table[0])))
    print("\nPart by part (r/mu), with the store's B:\n")
    per_part.append({"candidate": "Scenario B (store)", "reading": "S_geo",
                     "h": fmt(st.scene.h), **{f"{fmt(st.r[ri])}/{fmt(st.mu[mi])}": fmt(b[ri, mi])
                                              for ri, mi in st.parts()}})
    print(md_table(per_part, list(per_part[0])) + "\n")


#: Scenario B's readings: (cage score, whether P_j leaves out the points with tip_overlap).
B_READINGS = {"model (S_geo)": ("S_geo", False), "S_end": ("S_end", False),
              "P_j without tip_overlap": ("S_geo", True)}


def cmd_scenario_b(args) -> None:
    st = open_store(args.store)
    search = search_ranges(st)
    designs = [tuple(st.design(k)[d] for d in DESIGN_DIMS)
               for k in range(st.per_design("Lambda", 0, 0).size)]
    print(f"Scenario B per part, `{args.store}` ({st.attrs.get('effects_on')}), recomputed in "
          f"plain Python over the {len(designs):,} geometries (its check: B, poses and usage of "
          "the model's reading at the store's spacing against the store's), by reading and "
          "spacing; B in the store's units (times (h / "
          f"{fmt(st.scene.h)})^2).\n")
    readings = {k: v for k, v in B_READINGS.items() if k in args.reading}
    table, summary, started = [], {}, time.time()
    parts = args.part if args.part != ["all"] else [(float(r), float(mu)) for r in st.r
                                                   for mu in st.mu]
    for r, mu in parts:
        ri, mi = paper.Evidence(st).part(r, mu)
        for h in args.h:
            poses = {k: Poses() for k in readings}
            for d in designs:
                m = scene_map(st.scene, d, r, mu, h, forces=True)
                for k, (scale, drop) in readings.items():
                    rows, cols, lx, ly, rx, ry = counted_forces(m, scale, drop)
                    poses[k].add(rows, cols, lx + rx, ly + ry, np.array([d[4], *d[:4]]))
            for k in readings if h == st.scene.h else [k for k in readings if k in
                                                       ("model (S_geo)", "S_end")]:
                total, n, vert, every, low = metric(poses[k], search)
                line = {"part": f"r = {fmt(r)}, mu = {fmt(mu)}", "h": fmt(h), "reading": k,
                        "B": fmt(total * (h / st.scene.h) ** 2), "poses": n, "store": ""}
                if k.startswith("model") and h == st.scene.h:
                    line["store"] = (f"{fmt(float(st.ds['manipulation_b'].values[ri, mi]))} "
                                     f"({int(st.ds['manipulation_b_poses'].values[ri, mi])} "
                                     "poses; usage "
                                     + ", ".join(fmt(float(v)) for v in
                                                 st.ds["parameter_usage"].values[ri, mi]) + ")")
                for name, v in (("usage (vertices)", vert), ("usage (every counted)", every),
                                ("least vertex value", low)):
                    line[name] = ", ".join(f"{p} {fmt(x)}" for p, x in
                                           zip(("w", "l1", "l2", "r1", "r2"), v))
                table.append(line)
                if h == st.scene.h:
                    summary.setdefault(k, []).append(((r, mu), total, vert, every))
            log(f"scenario-b: r = {r:g}, mu = {mu:g}, h = {h:g} ({time.time() - started:.0f} s)")
    print(md_table(table, list(table[0])))
    print("\nUsage: per parameter (w, l1, l2, r1, r2), the range over the pose's geometries "
          "divided by the search range, averaged over the poses with a positive value "
          "(vertices: the geometries whose force is a vertex of the pose's hull, MODEL 10; every "
          "counted: every geometry whose force counts at the pose); 'least vertex value': the "
          "least value among the vertex geometries, as a fraction of the range above its lower "
          "bound (1: every vertex geometry at the upper bound).\n")
    if len(parts) > 1:
        print(f"Over the {len(parts)} parts, at h = {fmt(st.scene.h)}:\n")
        for k, got in summary.items():
            zero = [f"{fmt(r)}/{fmt(mu)}" for (r, mu), total, _, _ in got if total == 0]
            print(f"- {k}: B = 0 at r/mu " + (", ".join(zero) or "no part") + ".")
            for kind, col in (("vertices", 2), ("every counted", 3)):
                u = np.array([g[col] for g in got if g[1] > 0])
                print(f"  - usage ({kind}), parts at >= {paper.FULL_RANGE} of the "
                      f"{u.shape[0]} with a positive pose: "
                      + ", ".join(f"{p} {int(np.sum(u[:, i] >= paper.FULL_RANGE))} (mean "
                                  f"{fmt(float(u[:, i].mean()))})"
                                  for i, p in enumerate(("w", "l1", "l2", "r1", "r2"))) + ".")
        print()


# ---------------------------------------------------------------------------------------------
# The findings, as the report states them
# ---------------------------------------------------------------------------------------------
def cmd_findings(args) -> None:
    rows = []
    for path in args.stores:
        st = open_store(path)
        rows.append(paper.finding_rows(st, resolve_top_k(st, None)))
    if len(rows) == 2:
        table = paper.pair_rows(*rows)
        print("\n".join(paper.section(table, tuple(str(p) for p in args.stores))))
    else:
        print("\n".join(paper.section(rows[0])))


def part_arg(text: str) -> tuple[float, float]:
    r, mu = (float(v) for v in text.split(","))
    return r, mu


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0],
                                 formatter_class=argparse.RawDescriptionHelpFormatter)
    sub = ap.add_subparsers(dest="command", required=True)

    p = sub.add_parser("findings", help="the report's table of findings")
    p.add_argument("stores", type=Path, nargs="+")
    p.set_defaults(run=cmd_findings)

    p = sub.add_parser("palm", help="best palm width per part by scene, reading, spacing")
    p.add_argument("store", type=Path)
    p.add_argument("--radius", type=float, action="append", default=None,
                   help="part radius (every friction of the store) [0.4, 0.8]")
    p.add_argument("--h", type=float, default=0.025, help="spacing of the variants [0.025]")
    p.add_argument("--spacing", type=float, nargs="*", default=[0.1, 0.05, 0.0125],
                   help="other spacings to try [0.1 0.05 0.0125]")
    p.add_argument("--trajectory", nargs="*", default=["grid8", "continuous", "no-sampling"],
                   help="trajectory methods to try (no-sampling: step_resolution 0)")
    p.add_argument("--l1", type=float, default=None, help="chassis [the store's largest]")
    p.add_argument("--l2", type=float, default=None, help="chassis [the store's largest]")
    p.add_argument("--variant", nargs="+", default=list(PALM_GROUPS), choices=PALM_GROUPS,
                   help="groups of variants to compute [all]")
    p.add_argument("--readings-with", nargs="*", default=["scene"], choices=PALM_GROUPS,
                   help="groups whose maps also get the readings [scene]")
    p.set_defaults(run=cmd_palm)

    p = sub.add_parser("friction-trend", help="end points against friction, by what is counted")
    p.add_argument("stores", type=Path, nargs="+")
    p.add_argument("--tip-sample", type=int, default=0,
                   help="also a random sample of this many designs with tip_contact")
    p.add_argument("--seed", type=int, default=44)
    p.set_defaults(run=cmd_friction_trend)

    p = sub.add_parser("representatives", help="traits of caging- and tip-focused designs")
    p.add_argument("stores", type=Path, nargs="+")
    p.add_argument("--part", type=part_arg, default=(0.4, 1.0), help="r,mu [0.4,1.0]")
    p.add_argument("--fraction", type=float, default=0.1, help="group size [0.1]")
    p.set_defaults(run=cmd_representatives)

    p = sub.add_parser("ratio-focus", help="best caging R against tip-focused designs' R")
    p.add_argument("stores", type=Path, nargs="+")
    p.add_argument("--fraction", type=float, default=0.1, help="group size [0.1]")
    p.set_defaults(run=cmd_ratio_focus)

    p = sub.add_parser("scenario-a", help="Scenario A's best gripper by spacing and scale")
    p.add_argument("store", type=Path)
    p.add_argument("--top", type=int, default=3, help="the store's best candidates [3]")
    p.add_argument("--paper-gripper", type=lambda s: tuple(float(v) for v in s.split(",")),
                   default=(2.0, 1.6, 0.2, 0.14), help="l1,l2,r1,r2 [2.0,1.6,0.2,0.14]")
    p.add_argument("--spacing", type=float, nargs="+", default=[0.05, 0.025])
    p.add_argument("--scale", nargs="+", default=["S_geo", "S_end"], choices=["S_geo", "S_end"])
    p.set_defaults(run=cmd_scenario_a)

    p = sub.add_parser("scenario-b", help="Scenario B and parameter usage by reading")
    p.add_argument("store", type=Path)
    p.add_argument("--part", type=lambda t: "all" if t == "all" else part_arg(t),
                   action="append", required=True, help="r,mu (repeat), or all")
    p.add_argument("--h", type=float, nargs="+", default=[0.05], help="spacings [0.05]")
    p.add_argument("--reading", nargs="+", default=list(B_READINGS), choices=list(B_READINGS),
                   help="readings [all three]")
    p.set_defaults(run=cmd_scenario_b)

    args = ap.parse_args(argv)
    if args.command == "palm":
        args.radius = args.radius or [0.4, 0.8]
    args.run(args)
    return 0


if __name__ == "__main__":
    sys.exit(main())
