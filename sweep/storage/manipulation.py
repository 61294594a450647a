"""The store's manipulation variables (MODEL 10), merged from the item files' reductions.

Scenario A's (and C's) metric is per work item: `sweep.storage.store` writes it with the
summaries, a geometry group at a time. Scenario B's variables are per part and need every
geometry of the sweep: `part_arrays` merges each part's reductions over the item files holding
it, one range of its poses at a time, so that a merge holds no more as the sweep grows. The
variables and their attributes are declared in `sweep.schema` (`MANIPULATION_FIELDS`).
"""
from __future__ import annotations

import contextlib
from collections.abc import Sequence

import numpy as np

from ..compute.manipulation import (PARAMETER_NAMES, PartSource, merge_parts, part_keys,
                                    pose_cuts, usage_of)
from ..config.scene import Scene
from ..schema import STORE_FIELDS
from .h5 import write_coordinate
from .itemfile import ItemFile, manipulation_group

SCENARIO_C_NOTE = ("Scenario C: Scenario A's gripper whose fingers each present either the "
                   "part's mu or manipulation_scenario_c_mu_low (friction modulation, MODEL 10); "
                   "per pose the hull over every width, command and friction pair (mu_left, "
                   "mu_right); candidates as Scenario A's")


def candidate_variables(scene: Scene) -> tuple[str, ...]:
    """The store's variables per candidate (l1, l2, r1, r2) and part: Scenario A's, and C's."""
    names = ("manipulation_a", "manipulation_a_area")
    return names + (("manipulation_c", "manipulation_c_area") if scene.scenario_c else ())


def write_coordinates(f, scene: Scene) -> None:
    """The manipulation variables' own coordinates: parameter, pose_row, pose_column."""
    n_max = int(scene.lattice_columns().max())
    write_coordinate(f, "parameter", np.array(PARAMETER_NAMES, dtype=object),
                     STORE_FIELDS["parameter"].attrs())
    write_coordinate(f, "pose_row", np.arange(scene.lattice_rows() + 1, dtype=np.int32),
                     STORE_FIELDS["pose_row"].attrs())
    write_coordinate(f, "pose_column", np.arange(-n_max, n_max + 1, dtype=np.int32),
                     STORE_FIELDS["pose_column"].attrs())


#: Kept points of a part's reductions read from all its item files at once when they are merged:
#: the poses of a part are merged a range at a time (`part_arrays`), so that what a merge holds
#: stays flat as the sweep grows (one part of the paper sweep keeps up to 1,249 points at a pose
#: and 120,000 in all, a 4x sweep 4,594 and 244,000).
MERGE_ROWS = 1 << 16


def part_arrays(scene: Scene, item_files: Sequence[ItemFile]) -> dict[str, np.ndarray]:
    """The store's Scenario B variables (per part) from the reductions in the item files (files
    that tile every item, in item order).

    One part and one range of its poses at a time (`MERGE_ROWS`): a pose's hull depends only on
    its own points, so each range is merged over the item files holding the part in one pass
    (the states `ManipulationChunk.merge_stream` folds, bit for bit: a state is a function of
    its candidate set), and the per-pose values are joined in pose order before they are
    summed."""
    n_r, n_mu = len(scene.values["r"]), len(scene.values["mu"])
    n_cols = scene.lattice_columns()
    n_max, m = int(n_cols.max()), scene.lattice_rows()
    pose_value = np.zeros((n_r, n_mu, m + 1, 2 * n_max + 1))
    b = np.zeros((n_r, n_mu))
    b_uncrossed = np.zeros((n_r, n_mu))
    n_positive = np.zeros((n_r, n_mu), dtype=np.int32)
    usage = np.full((n_r, n_mu, len(PARAMETER_NAMES)), np.nan)
    search = np.array([max(scene.values[p]) - min(scene.values[p]) for p in PARAMETER_NAMES])
    holders: dict[tuple[int, int], list[ItemFile]] = {}
    for item_file in item_files:
        with manipulation_group(item_file.path) as g:
            for key in part_keys(g):
                holders.setdefault(key, []).append(item_file)
    for (ri, mui), held_by in sorted(holders.items()):
        width = 2 * int(n_cols[ri]) + 1
        pose_ids, values, ranges, uncrossed = [], [], [], []
        for merged in _merged_by_poses(held_by, (ri, mui), (m + 1) * width):
            v, r = merged["all"].values_and_ranges()
            pose_ids.append(merged["all"].pose_ids)
            values.append(v)
            ranges.append(r)
            uncrossed.append(merged["uncrossed"].values())
        values = np.concatenate(values)
        pose_rows, cols = np.divmod(np.concatenate(pose_ids), width)
        pose_value[ri, mui, pose_rows, cols - int(n_cols[ri]) + n_max] = values
        b[ri, mui] = values.sum()
        b_uncrossed[ri, mui] = np.concatenate(uncrossed).sum()
        n_positive[ri, mui] = int((values > 0).sum())
        usage[ri, mui] = usage_of(np.concatenate(ranges), values > 0.0, search)
    h2 = scene.h * scene.h
    return dict(manipulation_b=b, manipulation_b_area=b * h2, manipulation_b_uncrossed=b_uncrossed,
                manipulation_b_poses=n_positive, parameter_usage=usage,
                manipulation_b_pose_value=pose_value)


#: Item files held open at once while a part's poses are merged: far below the usual limit of
#: 1,024 open files (a cluster merge may have thousands of shards, each holding every part).
OPEN_ITEM_FILES = 64


@contextlib.contextmanager
def _part_sources(item_files: Sequence[ItemFile], key: tuple[int, int]):
    """The reductions of part `key` in each of `item_files`, their files open meanwhile."""
    with contextlib.ExitStack() as files:
        yield [PartSource(files.enter_context(manipulation_group(item_file.path)), key)
               for item_file in item_files]


def _merged_by_poses(held_by: Sequence[ItemFile], key: tuple[int, int], n_poses: int):
    """The reductions of part `key` (of a lattice of `n_poses` poses) merged over the item files
    holding it, one range of poses after another, each range's points from every file adding up
    to at most MERGE_ROWS (or one pose). A range is merged in one pass over every file's points
    (a pose's state is a function of its candidate set, kernels/hull.py: the streamed fold's
    hulls bit for bit, without rebuilding each pose once per file). The files stay open while
    the part is merged (opening one and looking up its datasets costs more than reading a
    range), unless there are more than OPEN_ITEM_FILES: then a range opens them OPEN_ITEM_FILES
    at a time."""
    batches = [held_by[i:i + OPEN_ITEM_FILES] for i in range(0, len(held_by), OPEN_ITEM_FILES)]
    with contextlib.ExitStack() as kept:
        held = kept.enter_context(_part_sources(held_by, key)) if len(batches) == 1 else None

        def over_files(work) -> list:
            if held is not None:
                return [work(source) for source in held]
            out = []
            for batch in batches:
                with _part_sources(batch, key) as sources:
                    out += [work(source) for source in sources]
            return out

        rows = np.zeros(n_poses, dtype=np.int64)
        for per_pose in over_files(lambda source: source.rows_per_pose(n_poses)):
            rows += per_pose
        for poses in pose_cuts(rows, MERGE_ROWS):
            yield merge_parts(over_files(lambda source, poses=poses: source.read(poses)))
