"""What accuracy costs in time: a ladder of accuracy settings on a sample of a config's maps,
compared with a reference at the finest setting (MODEL 8, docs/accuracy.md).

The study, in order:

1. *Default sweep.* Every map of the config at its own settings (the sweep's shared-field path),
   to find each part's best design (largest caging area, ties to the first design in config
   order).
2. *Sample* (deterministic): the cells (l1, l2, r1, r2) of a Halton sequence over the four axes'
   value indices (bases 2, 3, 5, 7; points 1..N; every cell when N is at least the number of
   cells), plus the cell of every part's best design; each
   sampled cell with every palm width and every part. So every part is in the sample, designs
   spread over the whole space, and each part's default best is in it.
3. *Ladder*: one axis varied at a time from the config's setting: h in {2h, h, h/2, h/4};
   reconfig_step from 0.2 to 0.002 rad; root_tol from 1e-3 to 1e-12; trajectory discrete or
   continuous. *Reference*: h/4, reconfig_step 0.002, root_tol 1e-12, discrete.
4. *Metrics* per setting, against the reference: seconds per map (and projected for the whole
   config), caging-area error (median, worst), top-1 agreement, top-5 overlap, Kendall tau.
   Caging area (Lambda h^2), not Lambda, is compared: Lambda grows as 1/h^2.

Ties: under equal tensions only R = r2/r1 matters, so designs that differ only in the scale of
(r1, r2) tie exactly. Two scores tie when they differ by at most TIE_REL times the larger. A
part's top-1 agrees when some design tied for best under the setting is also tied for best in
the reference. Top-5 overlap counts the setting's five best designs whose reference score
reaches the reference's fifth-best score (minus the tie tolerance).

Resumable: each finished step is written to its own file in the work directory (temporary name,
then renamed); a rerun with the same config and sample skips them.
"""
from __future__ import annotations

import csv
import hashlib
import itertools
import json
import math
import os
import time
from dataclasses import dataclass, replace
from pathlib import Path

import numpy as np

from .batch import summarize_cells
from .model import Accuracy, ModelInputError
from .outputs import write_text_atomic
from .scene import Scene
from .schema import SUMMARY_FIELDS

CAGING_AREA = SUMMARY_FIELDS.index("caging_area")
TIE_REL = 1e-9
DEFAULT_SAMPLE = 24
HALTON_BASES = (2, 3, 5, 7)
RECONFIG_LADDER = (0.2, 0.1, 0.05, 0.02, 0.01, 0.005, 0.002)
ROOT_TOL_LADDER = (1e-3, 1e-6, 1e-9, 1e-12)
REFERENCE_STEP, REFERENCE_TOL = 0.002, 1e-12
# A setting replaces the config's own only when measured this much cheaper: timings of one
# setting vary by about 10% from run to run on a shared machine (docs/performance.md).
MIN_SAVING = 0.10
CELL_AXES = ("l1", "l2", "r1", "r2")


@dataclass(frozen=True)
class Setting:
    """One rung of the ladder: the axis it varies and the full accuracy it runs at."""

    axis: str          # "h", "reconfig_step", "root_tol", "trajectory", or "reference"
    h: float
    accuracy: Accuracy

    @property
    def key(self) -> str:
        a = self.accuracy
        return (f"h{self.h:.6g}_s{a.reconfig_step:.6g}_t{a.root_tol:.3g}_{a.trajectory}")

    @property
    def label(self) -> str:
        a = self.accuracy
        return {"h": f"h = {self.h:g}", "reconfig_step": f"reconfig_step = {a.reconfig_step:g}",
                "root_tol": f"root_tol = {a.root_tol:g}", "trajectory": a.trajectory,
                "reference": "reference"}[self.axis]


def halton(index: int, base: int) -> float:
    """The index-th element (index >= 1) of the van der Corput sequence in `base`."""
    f, x = 1.0, 0.0
    while index > 0:
        f /= base
        x += f * (index % base)
        index //= base
    return x


def ladder(scene: Scene) -> tuple[list[Setting], Setting]:
    """The settings of the study (one axis at a time from the config's) and the reference."""
    h0, a0 = scene.h, scene.accuracy
    out: list[Setting] = []
    for h in (2 * h0, h0, h0 / 2, h0 / 4):
        out.append(Setting("h", h, a0))
    for s in RECONFIG_LADDER:
        out.append(Setting("reconfig_step", h0, replace(a0, reconfig_step=s)))
    for t in ROOT_TOL_LADDER:
        out.append(Setting("root_tol", h0, replace(a0, root_tol=t)))
    for m in ("discrete", "continuous"):
        out.append(Setting("trajectory", h0, replace(a0, trajectory=m)))
    reference = Setting("reference", h0 / 4, Accuracy(REFERENCE_STEP, REFERENCE_TOL, "discrete"))
    return out, reference


def is_default(setting: Setting, scene: Scene) -> bool:
    return setting.h == scene.h and setting.accuracy == scene.accuracy


# ---------------------------------------------------------------------------------------------
# Maps of a set of cells at one setting
# ---------------------------------------------------------------------------------------------
def design_cells(scene: Scene) -> np.ndarray:
    """Every (l1, l2, r1, r2) of the config, in config order: float64 (n, 4)."""
    return np.array(list(itertools.product(*(scene.values[a] for a in CELL_AXES))),
                    dtype=np.float64).reshape(-1, 4)


def parts(scene: Scene) -> list[tuple[float, float, int]]:
    """Every part (r, mu) under every command, in config order."""
    return [(r, mu, c) for r in scene.values["r"] for mu in scene.values["mu"]
            for c in range(len(scene.commands))]


def caging_areas(scene: Scene, cells4: np.ndarray, h: float, accuracy: Accuracy) -> np.ndarray:
    """Caging area of every map (cell, width, part): float64 (n_cells, n_w, n_parts)."""
    ps = parts(scene)
    out = np.empty((cells4.shape[0], scene.widths.size, len(ps)))
    for k, (r, mu, c) in enumerate(ps):
        cells = np.column_stack([cells4, np.full(len(cells4), r), np.full(len(cells4), mu)])
        rows = summarize_cells(cells, scene.widths, scene.commands[c], h, scene.limits, accuracy,
                               scene.effects)
        out[:, :, k] = rows[:, :, CAGING_AREA]
    return out


def save_atomic(path: Path, **arrays) -> None:
    tmp = path.with_name(f".{path.name}.{os.getpid()}.tmp")
    with open(tmp, "wb") as f:
        np.savez(f, **arrays)
    os.replace(tmp, path)


def cached(path: Path, compute) -> dict:
    """The arrays in `path`, or compute them (a dict), save them atomically and return them."""
    if path.exists():
        with np.load(path) as z:
            return {k: z[k] for k in z.files}
    arrays = compute()
    save_atomic(path, **arrays)
    return arrays


def timed_areas(scene: Scene, cells4: np.ndarray, setting: Setting) -> dict:
    # one cell first, untimed: loads (or compiles) the kernels this setting's path needs
    caging_areas(scene, cells4[:1], setting.h, setting.accuracy)
    started = time.perf_counter()
    areas = caging_areas(scene, cells4, setting.h, setting.accuracy)
    return dict(caging_area=areas, seconds=np.array(time.perf_counter() - started))


# ---------------------------------------------------------------------------------------------
# Sample
# ---------------------------------------------------------------------------------------------
def best_designs(areas: np.ndarray) -> np.ndarray:
    """Per part, the flat (cell, width) index of the best design (first of the tied ones)."""
    flat = areas.reshape(-1, areas.shape[-1])
    return np.array([tied_best(flat[:, k])[0] for k in range(flat.shape[1])], dtype=np.int64)


def sample_cells(scene: Scene, n_sample: int, default_areas: np.ndarray) -> np.ndarray:
    """Indices into design_cells(scene) of the sample: Halton points 1..n_sample over the four
    axes' value indices, then each part's default best cell; sorted, without repeats. A sample
    at least as large as the config's cells is every cell (without walking n_sample points)."""
    lens = [len(scene.values[a]) for a in CELL_AXES]
    if n_sample >= int(np.prod(lens)):
        return np.arange(int(np.prod(lens)), dtype=np.int64)
    chosen = []
    for n in range(1, n_sample + 1):
        idx = [min(int(halton(n, b) * m), m - 1) for b, m in zip(HALTON_BASES, lens)]
        chosen.append(int(np.ravel_multi_index(idx, lens)))
    n_w = scene.widths.size
    chosen += [int(b) // n_w for b in best_designs(default_areas)]
    return np.array(sorted(set(chosen)), dtype=np.int64)


# ---------------------------------------------------------------------------------------------
# Metrics
# ---------------------------------------------------------------------------------------------
def tie_tol(values: np.ndarray) -> float:
    return TIE_REL * max(1.0, float(np.max(np.abs(values)))) if values.size else 0.0


def tied_best(values: np.ndarray) -> np.ndarray:
    """Indices tied for the largest value (TIE_REL), in order."""
    return np.flatnonzero(values >= values.max() - tie_tol(values))


def top1_agrees(values: np.ndarray, reference: np.ndarray) -> bool:
    return bool(np.intersect1d(tied_best(values), tied_best(reference)).size)


def top5_overlap(values: np.ndarray, reference: np.ndarray, k: int = 5) -> float:
    k = min(k, values.size)
    mine = np.argsort(-values, kind="stable")[:k]
    kth = np.sort(reference)[::-1][k - 1]
    return float(np.sum(reference[mine] >= kth - tie_tol(reference))) / k


def kendall_tau(values: np.ndarray, reference: np.ndarray) -> float:
    """Kendall tau-b; 1 when both rankings are all ties (they agree), NaN-free."""
    from scipy.stats import kendalltau

    if np.ptp(values) == 0 and np.ptp(reference) == 0:
        return 1.0
    tau = kendalltau(values, reference).statistic
    return float(tau) if math.isfinite(tau) else 0.0


def metrics(areas: np.ndarray, reference: np.ndarray) -> dict:
    """Errors and ranking agreement of a setting's caging areas against the reference's, both
    (cells, widths, parts)."""
    err = np.abs(areas - reference).ravel()
    n_parts = areas.shape[-1]
    a = areas.reshape(-1, n_parts)
    r = reference.reshape(-1, n_parts)
    top1 = [top1_agrees(a[:, k], r[:, k]) for k in range(n_parts)]
    return dict(median_error=float(np.median(err)), worst_error=float(np.max(err)),
                top1_agreement=float(np.mean(top1)), n_parts_agree=int(np.sum(top1)),
                top5_overlap=float(np.mean([top5_overlap(a[:, k], r[:, k])
                                            for k in range(n_parts)])),
                kendall_tau=float(np.mean([kendall_tau(a[:, k], r[:, k])
                                           for k in range(n_parts)])))


# ---------------------------------------------------------------------------------------------
# The study
# ---------------------------------------------------------------------------------------------
@dataclass
class Study:
    scene: Scene
    n_sample: int
    sample: np.ndarray          # indices into design_cells
    n_maps_sample: int
    rows: list                  # one dict per setting
    reference: Setting
    recommended: dict
    seconds_default_sweep: float
    seconds_steps: float        # compute time of every step, summed from the work files
    best: list                  # per part: (part, best design at config / recommended / reference)


def check_sample(n_sample) -> None:
    if not (isinstance(n_sample, int) and n_sample >= 1):
        raise ModelInputError(f"--sample must be a whole number >= 1, got {n_sample!r}")


def work_dir_key(scene: Scene, n_sample: int) -> str:
    """Work files belong to one config (its hash) and one sample size."""
    return hashlib.sha256(f"{scene.config_hash}:{n_sample}".encode()).hexdigest()[:16]


def run_study(scene: Scene, n_sample: int, work: Path, progress=None) -> Study:
    """Run (or resume) the study; `progress(done, total, label)` is told after each step."""
    check_sample(n_sample)
    work.mkdir(parents=True, exist_ok=True)
    settings, reference = ladder(scene)
    total = len(settings) + 2
    all_cells = design_cells(scene)
    default = Setting("default", scene.h, scene.accuracy)
    full = cached(work / "default_sweep.npz", lambda: timed_areas(scene, all_cells, default))
    done = 1
    if progress:
        progress(done, total, "default sweep")
    sample = sample_cells(scene, n_sample, full["caging_area"])
    cells4 = all_cells[sample]
    n_maps = cells4.shape[0] * scene.widths.size * len(parts(scene))
    results = {}
    for s in [reference] + settings:
        results[s.key] = cached(work / f"{s.key}.npz", lambda s=s: timed_areas(scene, cells4, s))
        done += 1
        if progress:
            progress(done, total, s.label)
    ref = results[reference.key]["caging_area"]
    rows = []
    for s in settings + [reference]:
        res = results[s.key]
        per_map = float(res["seconds"]) / n_maps
        row = dict(axis=s.axis, setting=s.label, h=s.h,
                   reconfig_step=s.accuracy.reconfig_step, root_tol=s.accuracy.root_tol,
                   trajectory=s.accuracy.trajectory, default=is_default(s, scene),
                   seconds_per_map=per_map, projected_seconds=per_map * scene.n_maps)
        row.update(metrics(res["caging_area"], ref))
        rows.append(row)
    rec = recommend(rows)
    rec_setting = next(s for s in settings + [reference] if s.label == rec["setting"]
                       and s.axis == rec["axis"])
    cells_w = [(tuple(c), w) for c in cells4 for w in scene.widths]
    best = []
    for k, part in enumerate(parts(scene)):
        picks = []
        for s in (default, rec_setting, reference):
            key = Setting("h", scene.h, scene.accuracy).key if s is default else s.key
            flat = results[key]["caging_area"].reshape(-1, len(parts(scene)))[:, k]
            picks.append(cells_w[int(tied_best(flat)[0])])
        best.append((part, *picks))
    seconds = float(full["seconds"]) + sum(float(v["seconds"]) for v in results.values())
    return Study(scene, n_sample, sample, n_maps, rows, reference, rec, float(full["seconds"]),
                 seconds, best)


def recommend(rows: list) -> dict:
    """The cheapest setting whose best design equals the reference's for every part sampled;
    the config's own setting unless another is at least MIN_SAVING cheaper."""
    agreeing = [r for r in rows if r["axis"] != "reference" and r["top1_agreement"] == 1.0]
    default = next(r for r in rows if r["default"])
    if not agreeing:
        return default
    cheapest = min(agreeing, key=lambda r: r["seconds_per_map"])
    if default in agreeing and cheapest["seconds_per_map"] > (1 - MIN_SAVING) * \
            default["seconds_per_map"]:
        return default
    return cheapest


# ---------------------------------------------------------------------------------------------
# Outputs: CSV, markdown, plot
# ---------------------------------------------------------------------------------------------
COLUMNS = ("axis", "setting", "h", "reconfig_step", "root_tol", "trajectory", "default",
           "seconds_per_map", "projected_seconds", "median_error", "worst_error",
           "top1_agreement", "n_parts_agree", "top5_overlap", "kendall_tau")


def csv_text(study: Study) -> str:
    import io

    buf = io.StringIO()
    w = csv.DictWriter(buf, fieldnames=COLUMNS + ("recommended",), lineterminator="\n")
    w.writeheader()
    for r in study.rows:
        w.writerow({**{k: r[k] for k in COLUMNS}, "recommended": r is study.recommended})
    return buf.getvalue()


def _duration(seconds: float) -> str:
    return f"{seconds:.1f} s" if seconds < 120 else f"{seconds / 60:.1f} min"


def markdown(study: Study, command_line: str, wall_seconds: float) -> str:
    sc = study.scene
    rec = study.recommended
    n_parts = len(parts(sc))
    lines = [
        f"# Accuracy versus time: `{sc.name}`",
        "",
        f"Generated by `{command_line}`: its steps took {_duration(study.seconds_steps)} of "
        f"wall time in all (summed from the work files, so a resumed study counts every run "
        f"that contributed); this invocation {_duration(wall_seconds)}. Config hash "
        f"{sc.config_hash[:12]}, {os.cpu_count()} cores.",
        "",
        f"Sample: {len(study.sample)} cells (l1, l2, r1, r2) = {study.n_sample} Halton points "
        f"plus each part's best cell at the config's setting, x {sc.widths.size} palm widths x "
        f"{n_parts} parts = {study.n_maps_sample} maps per setting (of {sc.n_maps:,} in the "
        f"config). The config's setting ran on all its maps in "
        f"{_duration(study.seconds_default_sweep)} to find each part's best design.",
        "",
        f"Reference: h = {study.reference.h:g}, reconfig_step = {REFERENCE_STEP:g}, "
        f"root_tol = {REFERENCE_TOL:g}, discrete. Errors are absolute caging-area errors "
        "(Lambda h^2) against it; top-1 is the fraction of parts whose best design agrees "
        "(ties count as agreement); top-5 the mean overlap of the five best; tau the mean Kendall "
        "tau-b over parts. Time per map is this machine's wall time (shared with other jobs: "
        "pessimistic); projected = time per map x maps in the config.",
        "",
        "| axis | setting | s/map | projected | median err | worst err | top-1 | top-5 | tau |",
        "|---|---|---|---|---|---|---|---|---|",
    ]
    for r in study.rows:
        name = r["setting"] + (" (config)" if r["default"] else "")
        if r is rec:
            name = f"**{name} (recommended)**"
        lines.append(
            f"| {r['axis']} | {name} | {r['seconds_per_map'] * 1e3:.2f} ms | "
            f"{_duration(r['projected_seconds'])} | {r['median_error']:.3g} | "
            f"{r['worst_error']:.3g} | {r['n_parts_agree']}/{n_parts} | {r['top5_overlap']:.2f} | "
            f"{r['kendall_tau']:.3f} |")
    def design(cw):
        (l1, l2, r1, r2), w = cw
        return f"l1={l1:g} l2={l2:g} r1={r1:g} r2={r2:g} w={w:g}"

    lines += ["", "Best design per part in the sample (first of the tied ones, config order):",
              "", "| r | mu | command | config's setting | recommended | reference |",
              "|---|---|---|---|---|---|"]
    for (r, mu, c), at_default, at_rec, at_ref in study.best:
        lines.append(f"| {r:g} | {mu:g} | {c} | {design(at_default)} | {design(at_rec)} | "
                     f"{design(at_ref)} |")
    lines += [
        "",
        f"**Recommended**: {rec['setting']} (h = {rec['h']:g}, reconfig_step = "
        f"{rec['reconfig_step']:g}, root_tol = {rec['root_tol']:g}, {rec['trajectory']}): the "
        "cheapest setting whose best design equals the reference's for every part sampled; the "
        f"config's own setting is kept unless another is at least {MIN_SAVING:.0%} cheaper.",
        "",
    ]
    return "\n".join(lines)


def plot(study: Study, path: Path) -> None:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.ticker
    import matplotlib.pyplot as plt

    rows = [r for r in study.rows if r["axis"] != "reference"]
    fig, (ax1, ax2) = plt.subplots(2, 1, figsize=(7, 7), sharex=True)
    markers = {"h": "o", "reconfig_step": "s", "root_tol": "^", "trajectory": "D"}
    floor = 1e-16  # zero errors drawn at the floor of the log axis
    for axis, marker in markers.items():
        sel = [r for r in rows if r["axis"] == axis]
        t = [r["seconds_per_map"] for r in sel]
        ax1.scatter(t, [max(r["median_error"], floor) for r in sel], marker=marker, label=axis)
        ax2.scatter(t, [r["top1_agreement"] for r in sel], marker=marker, label=axis)
    rec = study.recommended
    for ax, y in ((ax1, max(rec["median_error"], floor)), (ax2, rec["top1_agreement"])):
        ax.scatter([rec["seconds_per_map"]], [y], s=250, facecolors="none", edgecolors="red",
                   linewidths=2, label="recommended")
    ax1.set_xscale("log")
    ax2.xaxis.set_minor_formatter(matplotlib.ticker.NullFormatter())  # overlapping labels
    ax1.set_yscale("log")
    ax2.set_ylim(-0.05, 1.05)
    ax1.set_ylabel("median caging-area error")
    ax2.set_ylabel("top-1 agreement (fraction of parts)")
    ax2.set_xlabel("seconds per map")
    ax1.legend(fontsize=8)
    ax1.set_title(f"Accuracy versus time: {study.scene.name}")
    fig.tight_layout()
    tmp = path.with_name(f".{path.name}.{os.getpid()}.tmp.png")
    fig.savefig(tmp, dpi=110)
    plt.close(fig)
    os.replace(tmp, path)


def write_outputs(study: Study, out: Path, command_line: str, wall_seconds: float) -> list[Path]:
    out.mkdir(parents=True, exist_ok=True)
    md, cs, png = out / "accuracy.md", out / "accuracy.csv", out / "accuracy.png"
    write_text_atomic(md, markdown(study, command_line, wall_seconds))
    write_text_atomic(cs, csv_text(study))
    plot(study, png)
    write_text_atomic(out / "sample.json", json.dumps(
        dict(config_hash=study.scene.config_hash, n_sample=study.n_sample,
             cells=design_cells(study.scene)[study.sample].tolist()), indent=1))
    return [md, cs, png]
