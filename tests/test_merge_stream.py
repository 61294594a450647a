"""The store is written one item file, one geometry group and one range of a part's poses at a
time (issue P13, scale: a merge's memory stays flat as the sweep grows, docs/performance.md). Its
content is bit for bit what writing the whole arrays at once gives, whatever the files' cut and
the batch sizes; the write stays atomic; a disk that refuses a write ends in one clean error.
"""
from __future__ import annotations

import errno
import io
import os
import shutil
import tempfile
from pathlib import Path
from unittest import mock

import h5py
import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from sweep.compute import manipulation as manip
from sweep.compute.batch import SUMMARY_FIELDS
from sweep.config.parse import load_scene, scene_from_dict
from sweep.files import OutputError, SpooledTemp, atomic_stream
from sweep.runs import runner
from sweep.runs.rundir import merge_shards, scan_shards
from sweep.schema import COUNT_FIELDS
from sweep.schema import A_DIMS
from sweep.storage import manipulation as store_manipulation, store
from sweep.storage.h5 import atomic_file
from sweep.storage.itemfile import KIND_PART, read_item_file, read_manipulation, write_item_file
from sweep.storage.store import CorruptFile, store_differences, write_store
from sweep_cases import item_file_in_memory, fake_items, tiny

CONFIG = Path(__file__).parent / "data" / "manipulation.yaml"


def in_memory(scene, start, stop):
    return item_file_in_memory(scene, fake_items(scene, start, stop), start)


def map_by_map(scene, full):
    """The store's summary variables built one map at a time: each item's row for each width
    put at the index of its own values (not the code's reshape and transpose)."""
    ix = scene.item_indices(0, scene.n_items)
    out = {name: np.zeros(scene.store_shape, np.int32 if name in COUNT_FIELDS else np.float64)
           for name in SUMMARY_FIELDS}
    for item in range(scene.n_items):
        for wi in range(len(scene.values["w"])):
            at = tuple(wi if d == "w" else ix[d][item] for d in scene.store_dims)
            for k, name in enumerate(SUMMARY_FIELDS):
                out[name][at] = full[item, wi, k]
    return out


# ---------------------------------------------------------------------------------------------
# Any cut of the items into item files: the same store, every map at its place
# ---------------------------------------------------------------------------------------------
SCENES = {"one-command": scene_from_dict(tiny()),
          "two-commands": scene_from_dict(tiny(commands=[{"f_left": 1.0, "f_right": 1.0},
                                                         {"f_left": 0.4, "f_right": 1.6}]))}


@pytest.mark.parametrize("name", SCENES)
@settings(max_examples=12)
@given(data=st.data())
def test_any_cut_into_item_files_writes_every_map_at_its_place(name, data):
    scene = SCENES[name]
    n = scene.n_items
    cuts = sorted(data.draw(st.sets(st.integers(1, n - 1), max_size=n - 1)))
    bounds = [0, *cuts, n]
    item_files = [in_memory(scene, a, b) for a, b in zip(bounds[:-1], bounds[1:])]
    item_files = data.draw(st.permutations(item_files))                  # any order given
    with tempfile.TemporaryDirectory() as tmp:
        cut, whole = Path(tmp) / "cut.h5", Path(tmp) / "whole.h5"
        write_store(cut, scene, item_files, {}, "test")
        write_store(whole, scene, [in_memory(scene, 0, n)], {}, "test")
        assert store_differences(cut, whole) == []
        want = map_by_map(scene, fake_items(scene, 0, n))
        with h5py.File(cut, "r") as f:
            for field, value in want.items():
                if field in f:
                    assert f[field].dtype == value.dtype
                    np.testing.assert_array_equal(f[field][...], value, err_msg=field)


def test_groups_are_read_one_item_file_at_a_time_in_item_order():
    scene = SCENES["one-command"]                   # 16 items in groups of 4
    item_files = [in_memory(scene, a, b) for a, b in ((0, 3), (3, 9), (9, 10), (10, 16))]
    read, seen = [], []

    def reader(b):
        read.append(b.start)
        return [b.data]

    for group, (items,) in store.iter_groups(scene, item_files, reader):
        seen.append((group, tuple(read)))
        np.testing.assert_array_equal(items, fake_items(scene, 4 * group, 4 * group + 4))
    # a group is given as soon as its last item file is read, and no later one was read before
    assert seen == [(0, (0, 3)), (1, (0, 3)), (2, (0, 3, 9, 10)), (3, (0, 3, 9, 10))]


# ---------------------------------------------------------------------------------------------
# The real sweep with the manipulation metric: chunks that split groups, tiny batches
# ---------------------------------------------------------------------------------------------
@pytest.fixture(scope="module")
def runs(tmp_path_factory, manipulation_store):
    """tests/data/manipulation.yaml (4 geometry groups of 4 items) run on one machine (the
    session's store, conftest.py) and in 6 chunks (so that chunks split groups)."""
    root = tmp_path_factory.mktemp("stream")
    scene = load_scene(CONFIG)
    shutil.copy2(manipulation_store, root / "whole.h5")
    for k in range(6):
        runner.run_chunk(scene, root / "run", k, 6, progress=False)
    return scene, root


def test_merged_store_is_the_one_machine_store_whatever_the_batch_sizes(runs, monkeypatch):
    scene, root = runs
    ranges = [s.range for s in scan_shards(root / "run").shards]
    assert any(a % scene.group_size or b % scene.group_size for a, b in ranges)
    merge_shards(root / "run", root / "merged.h5", overwrite=True)
    assert store_differences(root / "whole.h5", root / "merged.h5") == []
    # a few kept points per merge and per dense batch: 14 ranges of poses, many batches
    monkeypatch.setattr(store_manipulation, "MERGE_ROWS", 150)
    monkeypatch.setattr(manip, "BATCH_ROWS", 48)
    monkeypatch.setattr(manip, "POSE_BATCH", 5)
    merge_shards(root / "run", root / "small-batches.h5", overwrite=True)
    assert store_differences(root / "whole.h5", root / "small-batches.h5") == []
    # and the shards' files opened two at a time for each range, not held open for the part
    monkeypatch.setattr(store_manipulation, "OPEN_ITEM_FILES", 2)
    merge_shards(root / "run", root / "few-open.h5", overwrite=True)
    assert store_differences(root / "whole.h5", root / "few-open.h5") == []


def assert_manipulation_of(path, scene, chunks):
    """The store's Scenario B variables are those of every chunk's reductions merged in one pass,
    in memory (how the store was written before it was streamed), and Scenario A holds every
    item's metric at its own index."""
    at_once = manip.ManipulationChunk.merge_all(chunks)
    n_cols = scene.lattice_columns()
    n_max = int(n_cols.max())
    search = [max(scene.values[p]) - min(scene.values[p]) for p in manip.PARAMETER_NAMES]
    with h5py.File(path, "r") as f:
        assert at_once.parts
        for (ri, mui), reds in at_once.parts.items():
            values = reds["all"].values()
            assert values.max() > 0
            width = 2 * int(n_cols[ri]) + 1
            pose_value = np.zeros(f["manipulation_b_pose_value"].shape[2:])
            for pose, v in zip(reds["all"].pose_ids, values):
                pose_value[pose // width, pose % width - int(n_cols[ri]) + n_max] = v
            np.testing.assert_array_equal(f["manipulation_b_pose_value"][ri, mui], pose_value)
            assert f["manipulation_b"][ri, mui] == values.sum()
            assert f["manipulation_b_uncrossed"][ri, mui] == reds["uncrossed"].values().sum()
            assert f["manipulation_b_poses"][ri, mui] == (values > 0).sum()
            np.testing.assert_array_equal(f["parameter_usage"][ri, mui],
                                          reds["all"].parameter_usage(search))
        a = f["manipulation_a"][...]
        ix = scene.item_indices(0, scene.n_items)
        for item, value in enumerate(at_once.a_metric):
            assert a[tuple(ix[d][item] for d in A_DIMS)] == value


def test_part_variables_are_those_of_every_chunk_merged_at_once(runs):
    scene, root = runs
    shards = [s.path for s in scan_shards(root / "run").shards]
    assert_manipulation_of(root / "whole.h5", scene, [read_manipulation(p) for p in shards])


def random_chunk(scene, start, stop, rng):
    """Manipulation data of items [start, stop) with random forces at random poses of every
    part: many poses and many kept points, where the order of sums shows."""
    parts = {}
    n_rows = scene.lattice_rows() + 1
    for ri, n in enumerate(scene.lattice_columns()):
        for mui in range(len(scene.values["mu"])):
            reds = {}
            for name in ("all", "uncrossed"):
                k = int(rng.integers(50, 400))
                pose = rng.integers(0, n_rows * (2 * int(n) + 1), k)
                force = rng.normal(size=(k, 2)) * rng.uniform(0.1, 10.0, (k, 1))
                reds[name] = manip.PartReduction.from_entries(
                    pose, force[:, 0], force[:, 1], rng.integers(start, stop, k) * 7,
                    rng.uniform(0.0, 2.0, (k, 5)))
            parts[(ri, mui)] = reds
    return manip.ManipulationChunk(start, stop, rng.normal(size=stop - start), parts)


@pytest.mark.parametrize("seed", [1, 2])
def test_streamed_parts_equal_the_one_pass_merge_on_random_forces(seed, tmp_path, monkeypatch):
    rng = np.random.default_rng(seed)
    scene = scene_from_dict(tiny(outputs={"manipulation": True}))
    cuts = sorted(rng.choice(np.arange(1, scene.n_items), size=4, replace=False).tolist())
    bounds = [0, *cuts, scene.n_items]
    chunks, item_files = [], []
    for a, b in zip(bounds[:-1], bounds[1:]):
        chunks.append(random_chunk(scene, a, b, rng))
        path = tmp_path / f"part-{a}.h5"
        write_item_file(path, scene, a, b, fake_items(scene, a, b), KIND_PART, 0.0,
                    manipulation=chunks[-1])
        item_files.append(read_item_file(path, with_data=False))
    monkeypatch.setattr(store_manipulation, "MERGE_ROWS", 300)
    monkeypatch.setattr(manip, "BATCH_ROWS", 64)
    write_store(tmp_path / "s.h5", scene, item_files, {}, "test")
    assert_manipulation_of(tmp_path / "s.h5", scene, chunks)


@given(kept=st.lists(st.integers(0, 40), max_size=60), rows=st.integers(1, 100),
       poses=st.integers(1, 8))
def test_batches_cover_the_poses_within_their_bounds(kept, rows, poses):
    cuts = manip.batch_bounds(np.array(kept, dtype=np.int64), rows=rows, poses=poses)
    assert cuts[0] == 0 and cuts[-1] == len(kept) and cuts == sorted(set(cuts))
    for a, b in zip(cuts[:-1], cuts[1:]):
        assert b - a == 1 or ((b - a) * max(max(kept[a:b]), 1) <= rows and b - a <= poses)
    pieces = manip.pose_cuts(np.array(kept, dtype=np.int64), rows)
    assert [p for r in pieces for p in range(*r)] == list(range(len(kept)))
    assert all(b - a == 1 or sum(kept[a:b]) <= rows for a, b in pieces)


# ---------------------------------------------------------------------------------------------
# Atomic, and a refusing disk is one clean error
# ---------------------------------------------------------------------------------------------
def _tmp_files(directory: Path) -> list[str]:
    return [p.name for p in directory.iterdir() if ".tmp." in p.name]


def test_a_merge_that_fails_halfway_leaves_nothing(runs, tmp_path, monkeypatch):
    _, root = runs
    calls = []
    read = store._item_rows

    def fail_on_the_third(scene, b):
        calls.append(b.start)
        if len(calls) == 3:
            raise CorruptFile(f"{b.path.name}: unreadable (injected)")
        return read(scene, b)

    monkeypatch.setattr(store, "_item_rows", fail_on_the_third)
    out = tmp_path / "m.h5"
    with pytest.raises(CorruptFile, match="injected"):
        merge_shards(root / "run", out)
    assert len(calls) == 3
    assert sorted(p.name for p in tmp_path.iterdir()) == []     # no store, no temporary, no lock


def test_streamed_file_is_the_in_memory_file(tmp_path):
    data = np.arange(5000.0).reshape(50, 100)
    for stream, name in ((False, "memory.h5"), (True, "stream.h5")):
        with atomic_file(tmp_path / name, stream=stream) as f:
            ds = f.create_dataset("x", shape=data.shape, dtype=data.dtype, chunks=(7, 9),
                                  compression="gzip", shuffle=True)
            for i in range(0, 50, 3):
                ds[i:i + 3] = data[i:i + 3]
            f.attrs["note"] = "same"
    assert store_differences(tmp_path / "memory.h5", tmp_path / "stream.h5") == []
    assert _tmp_files(tmp_path) == []


OPS = st.lists(st.one_of(
    st.tuples(st.just("write"), st.integers(0, 300), st.binary(min_size=0, max_size=80)),
    st.tuples(st.just("read"), st.integers(0, 400), st.integers(0, 100)),
    st.tuples(st.just("truncate"), st.integers(0, 400), st.none()),
), max_size=25)


@given(ops=OPS, refuse_at=st.one_of(st.none(), st.integers(0, 24)), partial=st.booleans())
def test_spooled_file_reads_what_was_written_and_a_refusal_waits_for_commit(ops, refuse_at,
                                                                             partial):
    """Against an in-memory model: every read answers as the model does, before and after the
    disk refuses (ENOSPC at operation `refuse_at`, possibly after writing part of it); commit
    then raises the refusal and leaves nothing, or renames a file holding the model's bytes."""
    model = io.BytesIO()
    real_pwrite, real_ftruncate = os.pwrite, os.ftruncate
    state = {"op": -1}

    def pwrite(fd, data, offset):
        if state["op"] == refuse_at:
            if partial and len(data) > 1:
                real_pwrite(fd, bytes(data[:len(data) // 2]), offset)
            raise OSError(errno.ENOSPC, "No space left on device")
        return real_pwrite(fd, data, offset)

    def ftruncate(fd, size):
        if state["op"] == refuse_at:
            raise OSError(errno.ENOSPC, "No space left on device")
        return real_ftruncate(fd, size)

    with tempfile.TemporaryDirectory() as tmp:
        target = Path(tmp) / "f.bin"
        spool = SpooledTemp(target)
        with mock.patch("os.pwrite", pwrite), mock.patch("os.ftruncate", ftruncate):
            for k, (op, pos, arg) in enumerate(ops):
                state["op"] = k
                if op == "write":
                    spool.seek(pos)
                    model.seek(pos)
                    assert spool.write(bytearray(arg)) == len(arg)
                    model.write(arg)
                elif op == "read":
                    spool.seek(pos)
                    model.seek(pos)
                    assert spool.read(arg) == model.read(arg)
                else:
                    spool.truncate(pos)
                    size = len(model.getvalue())
                    model.truncate(pos)
                    if pos > size:
                        model.seek(size)
                        model.write(b"\0" * (pos - size))
                assert spool.seek(0, os.SEEK_END) == len(model.getvalue())
        refused = refuse_at is not None and refuse_at < len(ops) and \
            ops[refuse_at][0] in ("write", "truncate") and \
            (ops[refuse_at][0] == "truncate" or len(ops[refuse_at][2]) > 0)
        if refused:
            assert spool.refusal is not None and not spool.tmp.exists()
            with pytest.raises(OutputError, match="no space left on device"):
                spool.commit()
            assert os.listdir(tmp) == []
        else:
            spool.commit()
            assert target.read_bytes() == model.getvalue() and os.listdir(tmp) == ["f.bin"]


def test_atomic_stream_leaves_nothing_when_its_with_body_fails(tmp_path):
    with pytest.raises(RuntimeError), atomic_stream(tmp_path / "x.bin") as spool:
        spool.write(b"half")
        raise RuntimeError("interrupted")
    assert list(tmp_path.iterdir()) == []
