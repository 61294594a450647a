"""In-hand manipulation metric (MODEL 10): the per-part hull reductions, in plain Python.

A `PartReduction` holds, for every pose of one part's lattice that received a force, the exact
convex hull of the forces counted (plus which geometries gave each hull vertex), ragged. Chunks
of work items reduce their entries (`reduce`, `from_entries`), reductions merge (`merge_all`:
the hull of a union is the hull of the parts' hulls), and the result is read with `values` (the
Ferrari-Canny radius of each pose) and `parameter_usage`. Every order and every split gives
bitwise the same hulls, values and usage (kernels/hull.py: an exact orientation test). A batch
of poses is read through a dense `HullReduction` (fixed capacity per pose).
`ManipulationChunk` is a chunk's data: Scenario A per cell, Scenario B's reductions per part.
"""
from __future__ import annotations

from dataclasses import dataclass

import numba
import numpy as np

from ..grid import REDUCTIONS
from ..kernels import hull as _hull

PARAMETER_NAMES = ("w", "l1", "l2", "r1", "r2")
# The paper's search ranges, upper - lower (MODEL 1 table), in PARAMETER_NAMES order.
PAPER_SEARCH_RANGES = (2.0 - 0.0, 2.0 - 0.4, 1.6 - 0.4, 0.20 - 0.04, 0.18 - 0.02)
DEFAULT_CAPACITY = 16


def _pose_ranges() -> int:
    """Ranges of poses per kernel call: a few per thread, for load balance."""
    return 4 * numba.get_num_threads()


@dataclass
class HullReduction:
    """The dense state of a batch of poses, each with room for `capacity` kept points (hull
    vertices, then near points): kernels/hull.py for the meaning of the arrays."""

    points: np.ndarray        # (n_poses, capacity, 12) float64: x, y, param min[5], param max[5]
    first: np.ndarray         # (n_poses, capacity) int64: smallest geometry index of each point
    n_hull: np.ndarray        # (n_poses,) int64
    n_kept: np.ndarray        # (n_poses,) int64

    @classmethod
    def empty(cls, n_poses: int, capacity: int = DEFAULT_CAPACITY) -> "HullReduction":
        if n_poses < 0 or capacity < 1:
            raise ValueError("n_poses must be >= 0 and capacity >= 1")
        return cls(np.zeros((n_poses, capacity, _hull.N_COLS)),
                   np.zeros((n_poses, capacity), dtype=np.int64),
                   np.zeros(n_poses, dtype=np.int64), np.zeros(n_poses, dtype=np.int64))

    @property
    def n_poses(self) -> int:
        return self.points.shape[0]

    @property
    def capacity(self) -> int:
        return self.points.shape[1]

    # -----------------------------------------------------------------------------------------
    def values(self) -> np.ndarray:
        """Per-pose value: radius of the largest origin-centred circle inside the hull, else 0."""
        out = np.zeros(self.n_poses)
        _hull.reduction_values(self.points, self.n_hull, out)
        return out

    def parameter_ranges(self) -> np.ndarray:
        """(n_poses, 5): max - min of each parameter over the hull-vertex geometries, at poses
        with a positive value (0 elsewhere)."""
        ranges = np.zeros((self.n_poses, _hull.N_PARAMS))
        _hull.reduction_parameter_ranges(self.points, self.first, self.n_hull, self.n_kept,
                                         self.values(), ranges, _pose_ranges())
        return ranges

    def parameter_usage(self, search_ranges=PAPER_SEARCH_RANGES) -> np.ndarray:
        """MODEL 10 parameter usage: per parameter (w, l1, l2, r1, r2), the hull-vertex range
        divided by the search range, averaged over the poses with a positive value. NaN where
        no pose has a positive value, or where a search range is 0 (the usage is undefined)."""
        return usage_of(self.parameter_ranges(), self.values() > 0.0, search_ranges)

    @classmethod
    def from_arrays(cls, arrays: dict) -> "HullReduction":
        offsets = np.asarray(arrays["offsets"], dtype=np.int64)
        n_kept = np.diff(offsets)
        n_poses = n_kept.shape[0]
        n_hull = np.asarray(arrays["n_hull"], dtype=np.int64).copy()
        if n_hull.shape != (n_poses,) or (n_kept < n_hull).any() or (n_hull < 0).any():
            raise ValueError("inconsistent reduction arrays (offsets / n_hull)")
        out = cls.empty(n_poses, max(int(n_kept.max(initial=0)), 1))
        keep = np.arange(out.capacity)[None, :] < n_kept[:, None]
        rows = np.concatenate([np.asarray(arrays["force"], dtype=np.float64).reshape(-1, 2),
                               np.asarray(arrays["param_min"], dtype=np.float64).reshape(-1, 5),
                               np.asarray(arrays["param_max"], dtype=np.float64).reshape(-1, 5)],
                              axis=1)
        if rows.shape[0] != offsets[-1]:
            raise ValueError("inconsistent reduction arrays (row count)")
        out.points[keep] = rows
        out.first[keep] = np.asarray(arrays["first_geometry"], dtype=np.int64)
        out.n_hull[:] = n_hull
        out.n_kept[:] = n_kept
        return out


# ---------------------------------------------------------------------------------------------
# Sparse per-part reductions and the manipulation data of a chunk of work items
# ---------------------------------------------------------------------------------------------
#: Kept points reduced at once: a batch's dense per-pose arrays are (poses x capacity x 12)
#: doubles, its capacity its fullest pose's kept points, so a batch holds as many poses as fit
#: BATCH_ROWS padded rows (at most POSE_BATCH, at least one), poses of like size together. That
#: bounds the memory of a merge whatever the number of poses and however many points one pose
#: keeps (up to 1,249 in the paper sweep, where batches of 2,048 poses each padded to that took
#: 0.5 GB, and 4,594 in a sweep of 4x its designs).
POSE_BATCH = 2048
BATCH_ROWS = POSE_BATCH * DEFAULT_CAPACITY


def _raw_rows(fx, fy, params) -> np.ndarray:
    params = np.asarray(params, dtype=np.float64).reshape(-1, _hull.N_PARAMS)
    rows = np.empty((params.shape[0], _hull.N_COLS))
    rows[:, _hull.X] = fx
    rows[:, _hull.Y] = fy
    rows[:, _hull.PMIN:_hull.PMIN + _hull.N_PARAMS] = params
    rows[:, _hull.PMAX:_hull.PMAX + _hull.N_PARAMS] = params
    return rows


def usage_of(ranges: np.ndarray, positive: np.ndarray, search_ranges) -> np.ndarray:
    """MODEL 10 parameter usage from the poses' parameter ranges (n_poses, 5): their mean over
    the poses with a positive value, divided by the search ranges; NaN where no pose has a
    positive value, or where a search range is 0 (the usage is undefined)."""
    search_ranges = np.asarray(search_ranges, dtype=np.float64)
    if search_ranges.shape != (_hull.N_PARAMS,) or (search_ranges < 0).any():
        raise ValueError(f"search_ranges must be {_hull.N_PARAMS} non-negative numbers")
    if not positive.any():
        return np.full(_hull.N_PARAMS, np.nan)
    mean_range = ranges[positive].mean(axis=0)
    with np.errstate(divide="ignore", invalid="ignore"):
        return np.where(search_ranges > 0, mean_range / search_ranges, np.nan)


def batch_bounds(kept: np.ndarray, rows: int | None = None,
                 poses: int | None = None) -> list[int]:
    """Cuts 0 = c0 < c1 < ... = n of n poses with `kept` points each into consecutive batches of
    at most `poses` (POSE_BATCH) poses whose dense arrays (poses x the fullest pose's points) have
    at most `rows` (BATCH_ROWS) rows, or of one pose."""
    rows = BATCH_ROWS if rows is None else rows
    poses = POSE_BATCH if poses is None else poses
    cuts = [0]
    fullest = 0
    for p, k in enumerate(np.asarray(kept, dtype=np.int64).tolist()):
        fullest = max(fullest, k, 1)
        if p > cuts[-1] and ((p - cuts[-1] + 1) * fullest > rows or p - cuts[-1] == poses):
            cuts.append(p)
            fullest = max(k, 1)
    if len(kept):
        cuts.append(len(kept))
    return cuts


@dataclass
class PartReduction:
    """The Scenario B reduction of one part over the poses that ever received a force, stored
    ragged: `pose_ids` (sorted, unique flat lattice indices), per pose `n_hull` and its kept rows
    `rows[offsets[p]:offsets[p+1]]` (hull vertices first, CCW, then near points; kernels/hull.py)
    with their smallest geometry index `first`. Memory follows the kept points (19 per pose on
    average in the paper sweep, more as designs are added); every operation works on batches of
    poses (`batch_bounds`)."""

    pose_ids: np.ndarray
    offsets: np.ndarray
    n_hull: np.ndarray
    rows: np.ndarray
    first: np.ndarray

    @classmethod
    def reduce(cls, pose, rows, first) -> "PartReduction":
        """The reduction of points (rows with their pose's flat lattice index): every pose's
        state rebuilt from all its candidates at once (kernels/hull.py:
        reduction_rebuild_ragged). Non-finite forces are refused."""
        pose = np.asarray(pose, dtype=np.int64)
        rows = np.asarray(rows, dtype=np.float64).reshape(-1, _hull.N_COLS)
        if not np.isfinite(rows[:, :2]).all():
            raise ValueError("a counted force is not finite")
        order = np.argsort(pose, kind="stable")
        pose = pose[order]
        rows = np.ascontiguousarray(rows[order])
        first = np.ascontiguousarray(np.asarray(first, dtype=np.int64)[order])
        ids = np.unique(pose)
        seg = np.append(np.searchsorted(pose, ids, side="left"), pose.size).astype(np.int64)
        out_rows = np.empty_like(rows)
        out_first = np.empty_like(first)
        n_hull = np.zeros(ids.size, dtype=np.int64)
        n_kept = np.zeros(ids.size, dtype=np.int64)
        _hull.reduction_rebuild_ragged(seg, rows, first, out_rows, out_first, n_hull, n_kept,
                                       _pose_ranges())
        keep = np.arange(pose.size) < np.repeat(seg[:-1] + n_kept, np.diff(seg))
        offsets = np.zeros(ids.size + 1, dtype=np.int64)
        np.cumsum(n_kept, out=offsets[1:])
        return cls(ids, offsets, n_hull, out_rows[keep], out_first[keep])

    @classmethod
    def from_entries(cls, pose, fx, fy, geometry, params) -> "PartReduction":
        """Raw forces: entry e at flat lattice pose[e], from geometry[e] with params[e]."""
        return cls.reduce(pose, _raw_rows(fx, fy, params), np.asarray(geometry, dtype=np.int64))

    @classmethod
    def merge_all(cls, parts) -> "PartReduction":
        """The union of many reductions (the hull of a union is the hull of the parts' hulls)."""
        parts = list(parts)
        pose = np.concatenate([np.repeat(p.pose_ids, np.diff(p.offsets)) for p in parts])
        return cls.reduce(pose, np.concatenate([p.rows for p in parts]),
                          np.concatenate([p.first for p in parts]))

    def merge(self, other: "PartReduction") -> "PartReduction":
        return PartReduction.merge_all([self, other])

    def _batches(self):
        """Dense HullReductions of a batch of poses at a time: (the poses' indices, reduction).
        Poses go in order of their kept points (`batch_bounds`), so that a batch pads little."""
        kept = np.diff(self.offsets)
        order = np.argsort(kept, kind="stable")
        bounds = batch_bounds(kept[order])
        for p0, p1 in zip(bounds[:-1], bounds[1:]):
            poses = order[p0:p1]
            lengths = kept[poses]
            offsets = np.zeros(poses.size + 1, dtype=np.int64)
            np.cumsum(lengths, out=offsets[1:])
            rows = np.repeat(self.offsets[poses] - offsets[:-1], lengths) + np.arange(offsets[-1])
            yield poses, HullReduction.from_arrays(dict(
                offsets=offsets, n_hull=self.n_hull[poses], force=self.rows[rows, :2],
                param_min=self.rows[rows, _hull.PMIN:_hull.PMIN + _hull.N_PARAMS],
                param_max=self.rows[rows, _hull.PMAX:_hull.PMAX + _hull.N_PARAMS],
                first_geometry=self.first[rows]))

    def values(self) -> np.ndarray:
        """Per pose (of pose_ids) the MODEL 10 value: the inscribed radius of its hull."""
        out = np.zeros(self.pose_ids.size)
        for poses, red in self._batches():
            out[poses] = red.values()
        return out

    def values_and_ranges(self) -> tuple[np.ndarray, np.ndarray]:
        """Per pose (of pose_ids) its value and its parameter ranges (HullReduction's)."""
        values = np.zeros(self.pose_ids.size)
        ranges = np.zeros((self.pose_ids.size, _hull.N_PARAMS))
        for poses, red in self._batches():
            ranges[poses] = red.parameter_ranges()
            values[poses] = red.values()
        return values, ranges

    def parameter_usage(self, search_ranges=PAPER_SEARCH_RANGES) -> np.ndarray:
        """MODEL 10 parameter usage (see HullReduction.parameter_usage), over all poses."""
        values, ranges = self.values_and_ranges()
        return usage_of(ranges, values > 0.0, search_ranges)

    def to_arrays(self) -> dict:
        return dict(pose_ids=self.pose_ids, offsets=self.offsets, n_hull=self.n_hull,
                    rows=self.rows, first=self.first)

    @classmethod
    def from_arrays(cls, arrays: dict) -> "PartReduction":
        out = cls(*(np.asarray(arrays[k]) for k in ("pose_ids", "offsets", "n_hull", "rows",
                                                      "first")))
        if (out.offsets.shape != (out.pose_ids.size + 1,) or out.rows.shape[0] != out.offsets[-1]
                or out.first.shape[0] != out.offsets[-1]):
            raise ValueError("inconsistent part reduction arrays")
        return out


@dataclass
class ManipulationChunk:
    """The manipulation data of work items [start, stop): Scenario A's metric per item (cell)
    and, per part (index into the scene's r values, index into its mu values), the Scenario B
    reductions of the chunk's geometries."""

    start: int
    stop: int
    a_metric: np.ndarray                       # (stop - start,)
    parts: dict                                # (ri, mui) -> {"all": PartReduction, ...}
    a_pose_value: np.ndarray | None = None     # per-pose Scenario A values, when asked for
    c_metric: np.ndarray | None = None         # (stop - start,) with Scenario C, else None
    c_pose_value: np.ndarray | None = None     # per-pose Scenario C values, when asked for

    @classmethod
    def merge_all(cls, chunks) -> "ManipulationChunk":
        """Chunks of adjacent items (any order) as one: Scenario A's metrics side by side, each
        part's reductions merged in one pass."""
        chunks = sorted(chunks, key=lambda ch: ch.start)
        for a, b in zip(chunks, chunks[1:]):
            if a.stop != b.start:
                raise ValueError(f"chunks {a.start}-{a.stop} and {b.start}-{b.stop} are not "
                                 "adjacent")
        keys = sorted({key for ch in chunks for key in ch.parts})
        parts = {key: {name: PartReduction.merge_all([ch.parts[key][name] for ch in chunks
                                                      if key in ch.parts])
                       for name in REDUCTIONS} for key in keys}
        return cls(chunks[0].start, chunks[-1].stop,
                   np.concatenate([ch.a_metric for ch in chunks]), parts,
                   c_metric=joined_c_metrics([ch.c_metric for ch in chunks]))

    def merge(self, other: "ManipulationChunk") -> "ManipulationChunk":
        """Two chunks of adjacent items, in either order."""
        return ManipulationChunk.merge_all([self, other])

    @classmethod
    def merge_stream(cls, chunks) -> "ManipulationChunk":
        """Chunks of adjacent items, in item order, folded one at a time: at most the merged
        data and one chunk are held (merge_all holds every chunk at once, so its memory grew
        with the sweep). The hulls, values and usage are those of merge_all (the hull of a union
        is the hull of the parts' hulls); a part in only one chunk is kept as it is."""
        start = stop = None
        a_metric, parts, c_metric = [], {}, []
        for ch in chunks:
            if stop is not None and ch.start != stop:
                raise ValueError(f"chunk {ch.start}-{ch.stop} does not follow item {stop}")
            start = ch.start if start is None else start
            stop = ch.stop
            a_metric.append(ch.a_metric)
            c_metric.append(ch.c_metric)
            for key, reds in ch.parts.items():
                parts[key] = fold_part(parts.get(key), reds)
        if start is None:
            raise ValueError("no chunks to merge")
        return cls(start, stop, np.concatenate(a_metric), dict(sorted(parts.items())),
                   c_metric=joined_c_metrics(c_metric))

    def write(self, group) -> None:
        """Into an h5py group (an item file's `manipulation` group)."""
        group.attrs["item_start"] = self.start
        group.attrs["item_stop"] = self.stop
        group.create_dataset("a_metric", data=self.a_metric)
        if self.c_metric is not None:
            group.create_dataset("c_metric", data=self.c_metric)
        for (ri, mui), reds in sorted(self.parts.items()):
            for name in REDUCTIONS:
                g = group.create_group(f"part_{ri}_{mui}/{name}")
                for key, value in reds[name].to_arrays().items():
                    g.create_dataset(key, data=value)

    @classmethod
    def read(cls, group) -> "ManipulationChunk":
        parts = {key: read_part(group, key) for key in part_keys(group)}
        return cls(int(group.attrs["item_start"]), int(group.attrs["item_stop"]),
                   group["a_metric"][...], parts,
                   c_metric=group["c_metric"][...] if "c_metric" in group else None)


def joined_c_metrics(metrics: list) -> np.ndarray | None:
    """Scenario C's metrics of adjacent chunks side by side: None if they have none, an error if
    only some have them (the chunks of one sweep all have C or none does)."""
    have = {m is not None for m in metrics}
    if len(have) > 1:
        raise ValueError("chunks with and without Scenario C cannot be merged")
    return np.concatenate(metrics) if have == {True} else None


def fold_part(merged: dict | None, reds: dict) -> dict:
    """One part's reductions merged so far (None: none yet) with those of the next chunk in item
    order: what `ManipulationChunk.merge_stream` does for every part, so that a merge of one part
    at a time over the same chunks gives bitwise its hulls."""
    if merged is None:
        return dict(reds)
    return {name: merged[name].merge(reds[name]) for name in REDUCTIONS}


def merge_parts(reds: list) -> dict:
    """One part's reductions from several chunks (each as `read_part` gives them; None: the
    chunk has none of the part) merged in one pass: `fold_part` over them in any order gives
    the same states (a pose's state is a function of its candidate set), with each pose
    rebuilt once instead of once per chunk."""
    reds = [r for r in reds if r is not None]
    if len(reds) == 1:
        return dict(reds[0])
    return {name: PartReduction.merge_all([r[name] for r in reds]) for name in REDUCTIONS}


def part_keys(group) -> list[tuple[int, int]]:
    """The parts (r index, mu index) whose reductions a chunk's group (`write`) holds, sorted."""
    keys = []
    for name in group:
        if name.startswith("part_"):
            _, ri, mui = name.split("_")
            keys.append((int(ri), int(mui)))
    return sorted(keys)


class PartSource:
    """One part's reductions in a chunk's group (`write`), open for reading ranges of its poses:
    the datasets are looked up and the pose index read once (a merge reads every chunk's part a
    range of poses at a time, and h5py's lookups cost as much as the reads)."""

    def __init__(self, group, key: tuple[int, int]):
        name = f"part_{key[0]}_{key[1]}"
        self.present = name in group
        self.reductions = {}
        if self.present:
            for red in REDUCTIONS:
                g = group[name][red]
                self.reductions[red] = (g["pose_ids"][...], g["offsets"][...], g["n_hull"],
                                        g["rows"], g["first"])

    def read(self, poses: tuple[int, int] | None = None) -> dict | None:
        """The reductions of the part's poses whose lattice index lies in [poses[0], poses[1])
        (all if None; only their rows are read); None if the chunk has none of the part."""
        if not self.present:
            return None
        out = {}
        for red, (ids, offsets, n_hull, rows, first) in self.reductions.items():
            if poses is None:
                out[red] = PartReduction.from_arrays(dict(
                    pose_ids=ids, offsets=offsets, n_hull=n_hull[...], rows=rows[...],
                    first=first[...]))
                continue
            p0, p1 = np.searchsorted(ids, poses)
            a, b = offsets[p0], offsets[p1]
            out[red] = PartReduction.from_arrays(dict(
                pose_ids=ids[p0:p1], offsets=offsets[p0:p1 + 1] - a, n_hull=n_hull[p0:p1],
                rows=rows[a:b], first=first[a:b]))
        return out

    def rows_per_pose(self, n_poses: int) -> np.ndarray:
        """Per pose of the part's lattice (flat index < n_poses), its kept points, both
        reductions together (zeros if the chunk has none of the part)."""
        out = np.zeros(n_poses, dtype=np.int64)
        for ids, offsets, *_ in self.reductions.values():
            out += np.bincount(ids, weights=np.diff(offsets), minlength=n_poses).astype(np.int64)
        return out


def read_part(group, key: tuple[int, int], poses: tuple[int, int] | None = None) -> dict | None:
    """The reductions of one part from a chunk's group (`write`), of its poses whose lattice
    index lies in [poses[0], poses[1]) if given (only their rows are read); None if the group
    has no reductions of that part."""
    return PartSource(group, key).read(poses)


def pose_cuts(rows: np.ndarray, budget: int) -> list[tuple[int, int]]:
    """Consecutive ranges [lo, hi) of pose indices covering 0..len(rows) whose `rows` add up to
    at most `budget`, or of one pose."""
    cuts, lo, total = [], 0, 0
    for p, n in enumerate(np.asarray(rows, dtype=np.int64).tolist()):
        if p > lo and total + n > budget:
            cuts.append((lo, p))
            lo, total = p, 0
        total += n
    if len(rows):
        cuts.append((lo, len(rows)))
    return cuts
