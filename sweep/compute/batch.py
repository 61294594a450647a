"""A sweep of maps: per-map summaries for many designs and parts (MODEL 8, 10).

The unit of work is a *cell* ``(l1, l2, r1, r2, r, mu)`` evaluated for every palm width of the
sweep: the maps of one cell share finger geometry (a finger's field depends on the part centre
relative to its base, so all widths and both fingers are shifts/mirrors of one field).
"""
from __future__ import annotations

import threading

import numba
import numpy as np

from ..grid import (ENTRY_CAPACITY, REDUCTIONS, SCENARIO_A_EXTREMES,
                   grid_index_bounds, palm_half_width_steps, part_lattice_columns)
from ..config.scene import Scene, grid_points
from ..kernels import many_maps, one_map
from ..kernels.records import (CellMaps, ManipulationOut, RIGHT, LEFT, new_force_arrays,
                               new_outcome_arrays, new_finger_arrays, no_force_arrays,
                               no_manipulation, no_scenario_c, no_settled_fingers)
from ..model import Accuracy, Command, Design, Effects, Grid, Limits, ModelInputError, Part
from ..schema import SUMMARY_FIELDS, SUMMARY_INDEX
from .manipulation import ManipulationChunk, PartReduction
from .layout import (cells_as_kernels_read, contact_friction, finger_offsets, hand_record,
                     kernel_records, map_fields, map_grid, summary_attrs)
from .threads import over_ranges




def _cell_design_part(cell, w: float) -> tuple[Design, Part]:
    l1, l2, r1, r2, r, mu = (float(v) for v in cell)
    return Design(l1, l2, r1, r2, float(w)), Part(r, mu)


def cell_maps(cells: np.ndarray, widths: np.ndarray, h: float, command: Command,
              limits: Limits) -> CellMaps | None:
    """The kernels' record of `cells` (as `cells_as_kernels_read` gives them) at every width:
    each map on the default whole-reach grid of MODEL 8 at spacing h, columns -N .. N and rows
    0 .. M (sized without allocating them); None when a palm half-width is not a whole number
    of grid steps (no shared field then)."""
    steps = [palm_half_width_steps(w, h) for w in widths]
    if any(s is None for s in steps):
        return None
    bounds = [[grid_index_bounds(*_cell_design_part(c, w), Grid(h=h)) for w in widths]
              for c in cells]
    return CellMaps(
        cells=cells, widths=widths, palm_steps=np.array(steps, dtype=np.int64),
        ncols=np.array([[b[1] for b in row] for row in bounds], dtype=np.int64),
        nys=np.array([row[0][3] + 1 for row in bounds], dtype=np.int64), h=float(h),
        f_left=float(command.f_left), f_right=float(command.f_right),
        theta2_min=float(limits.theta2_min), theta2_max=float(limits.theta2_max))


def cell_maps_rows(maps: CellMaps, rows: np.ndarray) -> CellMaps:
    """The CellMaps of the cells `rows` of `maps`."""
    return maps._replace(cells=np.ascontiguousarray(maps.cells[rows]), ncols=maps.ncols[rows],
                         nys=maps.nys[rows])


def summarize_cells(cells: np.ndarray, widths: np.ndarray, command: Command, h: float,
                    limits: Limits, accuracy: Accuracy, effects: Effects = Effects(),
                    want: np.ndarray | None = None) -> np.ndarray:
    """Summaries of the maps of every cell at every width: float64 array (n_cells, n_w, n_fields).

    `cells` is float64 (n_cells, 6) with columns CELL_COLUMNS; `widths` float64 (n_w,); `want`
    bool (n_cells, n_w): the maps to compute (default all; the others' rows stay zero).
    Each map uses the default whole-reach grid of MODEL 8 at spacing `h`. Results are bitwise
    identical to `compute_map(...).attrs` for the same map.
    """
    cells = cells_as_kernels_read(cells, effects)
    widths = np.ascontiguousarray(widths, dtype=np.float64).reshape(-1)
    out = np.zeros((cells.shape[0], widths.size, len(SUMMARY_FIELDS)))
    if cells.shape[0] == 0 or widths.size == 0:
        return out
    want = (np.ones((cells.shape[0], widths.size), dtype=np.bool_) if want is None else
            np.ascontiguousarray(want, dtype=np.bool_).reshape(cells.shape[0], widths.size))
    _, solver, blocks = kernel_records(*_cell_design_part(cells[0], widths[0]), limits, accuracy,
                                       effects)
    maps = cell_maps(cells, widths, h, command, limits)
    if maps is not None:
        _summarize_on_shared_fields(maps, solver, blocks, out, want, no_manipulation())
        return out
    for c in range(cells.shape[0]):  # palm half-width off the grid: each map on its own
        for k, w in enumerate(widths):
            if not want[c, k]:
                continue
            design, part = _cell_design_part(cells[c], w)
            finger, _, _ = kernel_records(design, part, limits, accuracy, effects)
            g = map_grid(design, part, Grid(h=h))
            dx_left, dx_right = finger_offsets(g.i, w, h)
            hand = hand_record(w, command, h, finger)
            ny, nx = g.shape
            fingers = new_finger_arrays(2, ny, nx)
            one_map.finger_rows(0, ny, dx_left, g.y, finger, solver, blocks, fingers, LEFT)
            one_map.finger_rows(0, ny, dx_right, g.y, finger, solver, blocks, fingers, RIGHT)
            one_map.map_from_fingers(
                xs=g.x, ys=g.y, finger=finger, solver=solver, hand=hand, effects=blocks,
                fingers=fingers, outs=new_outcome_arrays(ny, nx), forces=no_force_arrays(),
                stack=np.empty(ny * nx, dtype=np.int64), summary=out[c, k],
                every_point=one_map.STABLE_POINTS, equilibrium=one_map.ALL_OUTPUTS,
                caging=one_map.ALL_OUTPUTS, settled=no_settled_fingers())
    return out


def _summarize_on_shared_fields(maps: CellMaps, solver, blocks, out, want, manip) -> None:
    """kernels.many_maps.summarize_cells over every cell of `maps`, ranges of cells on several
    threads (threads.over_ranges), each thread with its own memo of meetings."""
    collision = blocks.finger_collision.on
    n = maps.cells.shape[0]
    memo_shape = ((maps.widths.size, int(maps.nys.max()), 2 * int(maps.ncols.max()) + 1, 5)
                  if collision and n else (0, 0, 0, 5))
    thread_memo = threading.local()

    def cells_in_range(first, last):
        if not hasattr(thread_memo, "memo"):   # a thread's memo serves all its ranges
            thread_memo.memo = np.empty(memo_shape)
            thread_memo.key = np.full(2, np.nan)
        many_maps.summarize_cells(maps, first, last, solver, blocks, out, want, manip,
                                  thread_memo.memo, thread_memo.key)

    # Scenario C keeps its low-friction field across the cells of a range: then one range per
    # thread, of equal grid points (what a cell costs, to first order), as a smaller range would
    # compute it anew; else a cell per range, each thread taking the next as it finishes one
    # (the best balance; the meetings' memo is the thread's: docs/performance-log.md, "The sweep's
    # threads").
    if manip.c_mu_low.shape[0] > 0:
        points = maps.nys * ((2 * maps.ncols + 1) * want).sum(axis=1)
        over_ranges(n, cells_in_range, ranges_per_thread=1, costs=points)
    else:
        over_ranges(n, cells_in_range, ranges_per_thread=n)


def cell_map_fields(cell, w: float, command: Command, h: float, limits: Limits,
                    accuracy: Accuracy, effects: Effects = Effects(),
                    forces: bool = False) -> tuple[np.ndarray, np.ndarray, dict, dict]:
    """The per-point fields of one map computed the way the sweep computes it (shared finger
    field, mirrored and shifted): (x, y, fields, summary attrs), fields named as in
    sweep.schema. The palm half-width must be a whole number of grid steps."""
    design, part = _cell_design_part(cell, w)
    step = palm_half_width_steps(float(w), h)
    if step is None:
        raise ModelInputError(f"w = {w} is not a whole number of grid steps 2h = {2 * h}")
    finger, solver, blocks = kernel_records(design, part, limits, accuracy, effects)
    _, ncol, _, j1 = grid_index_bounds(design, part, Grid(h=h))
    ny = j1 + 1
    steps = np.array([step], dtype=np.int64)
    shared, m_lo, ys = many_maps.shared_finger_field(finger, solver, blocks, steps,
                                                     np.array([ncol], dtype=np.int64), ny,
                                                     float(h))
    xs, fingers = many_maps.gather_fingers(shared, m_lo, step, ncol, ny, float(h))
    outs = new_outcome_arrays(ny, xs.shape[0])
    force_arrays = new_force_arrays(ny, xs.shape[0]) if forces else no_force_arrays()
    summary = np.empty(len(SUMMARY_FIELDS))
    one_map.map_from_fingers(
        xs=xs, ys=ys, finger=finger, solver=solver, hand=hand_record(w, command, h, finger),
        effects=blocks, fingers=fingers, outs=outs, forces=force_arrays,
        stack=np.empty(ny * xs.shape[0], dtype=np.int64), summary=summary,
        every_point=one_map.EVERY_POINT, equilibrium=one_map.ALL_OUTPUTS,
        caging=one_map.ALL_OUTPUTS, settled=no_settled_fingers())
    return xs, ys, map_fields(fingers, outs, force_arrays if forces else None), \
        summary_attrs(summary)


# ---------------------------------------------------------------------------------------------
# The manipulation metric inside the sweep (MODEL 10)
# ---------------------------------------------------------------------------------------------
def _splice(whole: np.ndarray, redone: np.ndarray, rows: np.ndarray) -> np.ndarray:
    """Rows `rows` of `whole` replaced by `redone` (widened along axis 1 when it is wider)."""
    if whole.ndim == 2 and redone.shape[1] > whole.shape[1]:
        wide = np.zeros((whole.shape[0], redone.shape[1]), dtype=whole.dtype)
        wide[:, :whole.shape[1]] = whole
        whole = wide
    whole = whole.copy()
    whole[rows, ...] = redone if whole.ndim == 1 else redone[:, :whole.shape[1]]
    return whole


def manipulation_cells(cells: np.ndarray, widths: np.ndarray, h: float, limits: Limits,
                       accuracy: Accuracy, effects: Effects, items: np.ndarray,
                       part_keys: np.ndarray, lattice_ncol: np.ndarray, *,
                       capacity: int = ENTRY_CAPACITY, command: Command = Command(),
                       pose_values: bool = False, mu_low: float | None = None
                       ) -> tuple[np.ndarray, ManipulationChunk]:
    """Summaries (as `summarize_cells` under `command`) and the manipulation data of cells
    whose items are `items` (consecutive work-item indices): Scenario A's metric per cell and
    Scenario B's reductions per part (`part_keys[c]` = (r index, mu index) of cell c, whose
    lattice has columns -lattice_ncol[c] .. lattice_ncol[c]). Geometry index of a map: its item
    index x n_w + its width index. With `mu_low` (Scenario C's low friction, MODEL 10), also
    Scenario C's metric per cell (`chunk.c_metric`). With `pose_values`, the chunk also carries
    the value of every pose of Scenario A (`chunk.a_pose_value[c]`, on the grid of the cell's
    widest map) and of C (`chunk.c_pose_value`)."""
    cells = cells_as_kernels_read(cells, effects)
    widths = np.ascontiguousarray(widths, dtype=np.float64).reshape(-1)
    items = np.asarray(items, dtype=np.int64)
    n = cells.shape[0]
    maps = cell_maps(cells, widths, h, command, limits)
    if maps is None:
        raise ModelInputError("the manipulation metric needs every palm half-width to be a whole "
                              f"number of grid steps (w a multiple of 2h = {2 * h:g})")
    _, solver, blocks = kernel_records(*_cell_design_part(cells[0], widths[0]), limits, accuracy,
                                       effects)
    lattice_ncol = np.ascontiguousarray(lattice_ncol, dtype=np.int64)
    if mu_low is not None:
        mu_low = contact_friction(mu_low, effects)

    def run(rows, capacity):
        out = np.zeros((rows.size, widths.size, len(SUMMARY_FIELDS)))
        m = rows.size
        shape = ((m, int(maps.nys[rows].max()), 2 * int(maps.ncols[rows].max()) + 1)
                 if pose_values else (0, 0, 0))
        scenario_c = no_scenario_c() if mu_low is None else (
            np.array([mu_low], dtype=np.float64), np.zeros(m),
            np.zeros(shape))
        manip = ManipulationOut(
            np.zeros((m, capacity), dtype=np.int64), np.zeros((m, capacity)),
            np.zeros((m, capacity)), np.zeros((m, capacity), dtype=np.int64),
            np.zeros((m, capacity), dtype=np.bool_), np.zeros(m, dtype=np.int64), np.zeros(m),
            lattice_ncol[rows], np.array(SCENARIO_A_EXTREMES, dtype=np.float64),
            np.zeros(shape), *scenario_c)
        _summarize_on_shared_fields(cell_maps_rows(maps, rows), solver, blocks, out,
                                    np.ones((rows.size, widths.size), dtype=np.bool_), manip)
        return out, manip

    out, manip = run(np.arange(n), capacity)
    over = np.flatnonzero(manip.n_entries > capacity)
    if over.size:  # redo only the cells with more counted poses than the buffer holds
        out2, manip2 = run(over, int(manip.n_entries.max()))
        out[over] = out2
        manip = ManipulationOut(
            *[_splice(a, b, over) for a, b in zip(manip[:7], manip2[:7])],
            manip.lattice_ncol, manip.a_commands,
            _splice(manip.a_pose_value, manip2.a_pose_value, over) if pose_values
            else manip.a_pose_value, manip.c_mu_low,
            _splice(manip.c_metric, manip2.c_metric, over) if mu_low is not None
            else manip.c_metric,
            _splice(manip.c_pose_value, manip2.c_pose_value, over)
            if pose_values and mu_low is not None else manip.c_pose_value)
    parts: dict = {}
    keys = [tuple(int(v) for v in k) for k in np.asarray(part_keys).reshape(-1, 2)]
    for key in sorted(set(keys)):
        rows = [c for c in range(n) if keys[c] == key]
        pose, fx, fy, geom, params, crossed = [], [], [], [], [], []
        for c in rows:
            m = int(manip.n_entries[c])
            k = manip.width[c, :m]
            l1, l2, r1, r2 = cells[c, :4]
            pose.append(manip.pose[c, :m])
            fx.append(manip.fx[c, :m])
            fy.append(manip.fy[c, :m])
            geom.append(items[c] * widths.size + k)
            params.append(np.column_stack([widths[k], np.full((m, 4), (l1, l2, r1, r2))]))
            crossed.append(manip.crossed[c, :m])
        pose, fx, fy, geom = (np.concatenate(v) for v in (pose, fx, fy, geom))
        params = np.concatenate(params).reshape(-1, 5)
        crossed = np.concatenate(crossed)
        keep = ~crossed
        parts[key] = {
            "all": PartReduction.from_entries(pose, fx, fy, geom, params),
            "uncrossed": PartReduction.from_entries(pose[keep], fx[keep], fy[keep], geom[keep],
                                                    params[keep]),
        }
        assert tuple(parts[key]) == REDUCTIONS
    start = int(items[0]) if n else 0
    chunk = ManipulationChunk(start, start + n, manip.a_metric.copy(), parts,
                              c_metric=None if mu_low is None else manip.c_metric.copy())
    if pose_values:
        chunk.a_pose_value = manip.a_pose_value
        if mu_low is not None:
            chunk.c_pose_value = manip.c_pose_value
    return out, chunk


def scenario_a_pose_values(candidate, part, widths, h: float, limits: Limits = Limits(),
                           accuracy: Accuracy = Accuracy(), effects: Effects = Effects()):
    """Scenario A per pose for one candidate (l1, l2, r1, r2) and part (r, mu) over `widths`
    (MODEL 10): (x, y, values) on the grid of the widest map, and the metric (their sum)."""
    return _candidate_pose_values(candidate, part, widths, h, limits, accuracy, effects, None)


def scenario_c_pose_values(candidate, part, widths, h: float, mu_low: float,
                           limits: Limits = Limits(), accuracy: Accuracy = Accuracy(),
                           effects: Effects = Effects()):
    """Scenario C per pose (MODEL 10: A's gripper whose fingers each switch between the part's
    mu and `mu_low`), as `scenario_a_pose_values`."""
    return _candidate_pose_values(candidate, part, widths, h, limits, accuracy, effects, mu_low)


def _candidate_pose_values(candidate, part, widths, h, limits, accuracy, effects, mu_low):
    cell = np.array([[*candidate, *part]], dtype=np.float64)
    widths = np.asarray(widths, dtype=np.float64)
    n_col = part_lattice_columns(widths.max(), candidate[0], candidate[1], part[0], h)
    _, chunk = manipulation_cells(cell, widths, h, limits, accuracy, effects, np.array([0]),
                                  np.array([[0, 0]]), np.array([n_col]), pose_values=True,
                                  mu_low=mu_low)
    values, metric = ((chunk.a_pose_value[0], chunk.a_metric[0]) if mu_low is None
                      else (chunk.c_pose_value[0], chunk.c_metric[0]))
    ny, nx = values.shape
    x = (np.arange(nx) - nx // 2) * h
    y = part[0] + np.arange(ny) * h
    return x, y, values, float(metric)


# ---------------------------------------------------------------------------------------------
# Maps of the refinement stage: a few widths of many cells (sweep.runs.refine)
# ---------------------------------------------------------------------------------------------
def commanded_cell_of_maps(designs: np.ndarray, parts: np.ndarray, keys: np.ndarray) -> np.ndarray:
    """Per map (part, design) of `keys`, its cell with its command: (command, l1, l2, r1, r2,
    r index, mu index) as a row of float64 (n, 7), a key (not a cell row of CELL_COLUMNS: the
    part by its indices); maps with one key share the finger field."""
    p, d = parts[keys[:, 0]], designs[keys[:, 1]]
    return np.column_stack([p[:, 2], d[:, :4], p[:, 0], p[:, 1]]).astype(np.float64)


def caging_areas(scene: Scene, designs: np.ndarray, parts: np.ndarray, keys: np.ndarray,
                 h: float) -> np.ndarray:
    """Caging area of the maps `keys` ((n, 2): part, design) at spacing h, with the scene's
    limits, accuracy and effects, by the sweep's own path (`summarize_cells`): each cell (design
    without w, part, command) once, computing only the widths of its maps in `keys` (`want`; one
    finger field serves them all); one call per (command, set of widths), the small sets of a
    command in one call at the union of their widths, its cells in parallel, largest first.
    (Measured against one call per width and against whole cells at every width:
    docs/performance.md; the union's waste: model-notes D28.)"""
    out = np.empty(keys.shape[0])
    index: dict = {}
    which = np.array([index.setdefault(tuple(c), len(index))
                      for c in commanded_cell_of_maps(designs, parts, keys)], dtype=np.int64)
    cells = np.array(list(index), dtype=np.float64).reshape(-1, 7)
    w_index = keys[:, 1] % scene.widths.size           # designs in store order: w fastest
    widths_of = [set() for _ in range(cells.shape[0])]
    for c, wi in zip(which, w_index):
        widths_of[c].add(int(wi))
    groups: dict = {}
    for c in range(cells.shape[0]):
        groups.setdefault((int(cells[c, 0]), tuple(sorted(widths_of[c]))), []).append(c)
    # A call with fewer cells than threads leaves threads idle: the small groups of a command
    # run as one call at the union of their widths, each cell computing only the maps of its own
    # widths (`want`; the shared field spans the union, a small part of the work).
    threads = numba.get_num_threads()
    merged: dict = {}
    for (ci, ws), rows in list(groups.items()):
        if len(rows) < 2 * threads:
            del groups[(ci, ws)]
            union, members = merged.get(ci, (set(), []))
            merged[ci] = (union | set(ws), members + rows)
    for ci, (union, rows) in merged.items():
        groups.setdefault((ci, tuple(sorted(union))), []).extend(sorted(rows))
    r_vals, mu_vals = np.asarray(scene.values["r"]), np.asarray(scene.values["mu"])
    calls = []
    for (ci, ws), rows in groups.items():
        # One call of the group's cells, largest first: the threads take its cells one at a
        # time, each the next as it finishes one (_summarize_on_shared_fields), so no thread
        # waits for another's last cell until the group's end (calls of `threads` cells each
        # did, at every call: docs/performance.md).
        cost = [sum(grid_points(cells[c, 1], cells[c, 2], scene.widths[wi],
                                r_vals[int(cells[c, 5])], h) for wi in widths_of[c])
                for c in rows]
        calls.append((ci, ws, [rows[k] for k in sorted(range(len(rows)),
                                                      key=lambda k: (-cost[k], k))]))
    for ci, ws, rows in calls:
        c = cells[rows]
        want = np.array([[wi in widths_of[r] for wi in ws] for r in rows], dtype=np.bool_)
        res = summarize_cells(
            np.column_stack([c[:, 1:5], r_vals[c[:, 5].astype(int)], mu_vals[c[:, 6].astype(int)]]),
            scene.widths[list(ws)], scene.commands[ci], h, scene.limits, scene.accuracy,
            scene.effects, want)
        at = np.full(cells.shape[0], -1)
        at[rows] = np.arange(len(rows))
        mine = np.flatnonzero(at[which] >= 0)
        column = {wi: k for k, wi in enumerate(ws)}
        out[mine] = res[at[which[mine]], [column[int(wi)] for wi in w_index[mine]],
                        SUMMARY_INDEX["caging_area"]]
    return out
