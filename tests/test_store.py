"""Results store, shards and parts: layout, self-description, status and merge refusals.

The summaries here come from `sweep_cases.fake_summaries`: these tests are about bookkeeping.
"""
import h5py
import numpy as np
import pytest
import xarray as xr

from sweep import __version__
from sweep.compute.batch import SUMMARY_FIELDS
from sweep.schema import EFFECT_SUMMARY
from sweep.config.chunks import chunk_ranges
from sweep.model import Command
from sweep.config.scene import STORE_DIMS
from sweep.config.parse import scene_from_dict, scene_from_frozen
from sweep.runs.rundir import RunDir, ensure_manifest, merge_shards, scan_shards
from sweep.schema import COUNT_FIELDS
from sweep.storage.itemfile import KIND_PART, KIND_SHARD, assemble, read_item_file, write_item_file
from sweep.storage.store import CorruptFile, StoreError, read_store, store_arrays, write_store
from sweep_cases import item_file_in_memory, fake_items, fake_summaries, tiny


def write_shards(scene, root, n_chunks):
    rundir = RunDir(root)
    ensure_manifest(rundir, scene, n_chunks)
    ranges = chunk_ranges(scene.n_items, n_chunks, scene.group_size, scene.group_costs())
    for k, (a, b) in enumerate(ranges):
        write_item_file(rundir.shard(k, n_chunks), scene, a, b, fake_items(scene, a, b), KIND_SHARD,
                    compute_seconds=1.0, chunk=k, n_chunks=n_chunks)
    return rundir


@pytest.fixture
def scene():
    return scene_from_dict(tiny())


def test_item_file_round_trip(tmp_path, scene):
    data = fake_items(scene, 3, 7)
    path = tmp_path / "items.h5"
    write_item_file(path, scene, 3, 7, data, KIND_PART, compute_seconds=0.5)
    b = read_item_file(path)
    assert (b.kind, b.start, b.stop, b.config_hash, b.version) == \
        (KIND_PART, 3, 7, scene.config_hash, __version__)
    np.testing.assert_array_equal(b.data, data)
    assert b.frozen["resolved"] == scene.resolved()


def test_item_file_of_wrong_shape_is_not_written(tmp_path, scene):
    with pytest.raises(ValueError):
        write_item_file(tmp_path / "x.h5", scene, 0, 4, np.zeros((3, 2, len(SUMMARY_FIELDS))),
                    KIND_PART, 0.0)
    assert not list(tmp_path.iterdir())


@pytest.mark.parametrize("damage", ["truncate", "garbage", "foreign-hdf5"])
def test_damaged_item_file_is_corrupt(tmp_path, scene, damage):
    path = tmp_path / "items.h5"
    write_item_file(path, scene, 0, 4, fake_items(scene, 0, 4), KIND_PART, 0.0)
    if damage == "truncate":
        raw = path.read_bytes()
        path.write_bytes(raw[: len(raw) // 2])
    elif damage == "garbage":
        path.write_bytes(b"\x00" * 4096)
    else:
        path.unlink()
        with h5py.File(path, "w") as f:
            f["summaries"] = np.zeros(3)
    with pytest.raises(CorruptFile):
        read_item_file(path)


def test_store_axes_follow_the_item_numbering(scene):
    """Value at store index (l1, l2, r1, r2, w, r, mu) is the summary of exactly that map."""
    full = fake_items(scene, 0, scene.n_items)
    arrays = store_arrays(scene, full)
    assert arrays["Lambda"].shape == scene.store_shape
    v = scene.values
    for idx in np.ndindex(scene.store_shape):
        point = {d: v[d][i] for d, i in zip(STORE_DIMS, idx)}
        cell = np.array([[point[c] for c in ("l1", "l2", "r1", "r2", "r", "mu")]])
        want = fake_summaries(cell, np.array([point["w"]]), scene.commands[0], scene.h,
                              scene.limits, scene.accuracy)[0, 0]
        got = [arrays[f][idx] for f in SUMMARY_FIELDS]
        np.testing.assert_array_equal(got, want)


def test_several_commands_add_a_command_dimension(tmp_path):
    s = scene_from_dict(tiny(commands=[{"f_left": 1.0, "f_right": 1.0},
                                       {"f_left": 0.4, "f_right": 1.6}]))
    full = fake_items(s, 0, s.n_items)
    path = tmp_path / "r.h5"
    write_store(path, s, [item_file_in_memory(s, full)], timings={}, created_by="test")
    with xr.open_dataset(path, engine="h5netcdf") as ds:
        assert ds["Lambda"].dims == STORE_DIMS + ("command",)
        np.testing.assert_array_equal(ds["f_left"].values, [1.0, 0.4])
        # fake Lambda carries + f_left: the command axis really is the command
        diff = ds["Lambda"].isel(command=0) - ds["Lambda"].isel(command=1)
        np.testing.assert_allclose(diff.values, 0.6)
        assert Command(0.4, 1.6) == s.commands[1]


def test_store_describes_itself(tmp_path, scene):
    path = tmp_path / "r.h5"
    write_store(path, scene, [item_file_in_memory(scene, fake_items(scene, 0, scene.n_items))],
                timings=dict(wall_seconds=2.0, compute_seconds=1.0, maps_per_second=32.0),
                created_by="test")
    with xr.open_dataset(path, engine="h5netcdf") as ds:
        assert tuple(ds["Lambda"].dims) == STORE_DIMS
        assert dict(ds.sizes) == dict(zip(STORE_DIMS, scene.store_shape))
        for d in STORE_DIMS:
            np.testing.assert_array_equal(ds[d].values, scene.values[d])
            assert ds[d].attrs["units"] and ds[d].attrs["long_name"]
        for f in SUMMARY_FIELDS:
            if f in EFFECT_SUMMARY:  # only with its effect on
                assert f not in ds
                continue
            assert ds[f].attrs["long_name"] and ds[f].attrs["units"]
            assert (ds[f].dtype == np.int32) == (f in COUNT_FIELDS)
        for key in ("config", "config_resolved", "config_hash", "effects_on", "grid_h",
                    "sweep_version", "numba_version", "hdf5_version", "wall_seconds",
                    "maps_per_second"):
            assert key in ds.attrs, key
        assert ds.attrs["config_hash"] == scene.config_hash
        assert ds.attrs["effects_on"] == "friction"
    view = read_store(path)
    assert scene_from_frozen(view.frozen).config_hash == scene.config_hash
    want = store_arrays(scene, fake_items(scene, 0, scene.n_items))["n_caged"]
    np.testing.assert_array_equal(view.variables["n_caged"], want)


def test_non_integral_counts_are_refused(scene):
    full = fake_items(scene, 0, scene.n_items)
    full[0, 0, SUMMARY_FIELDS.index("n_caged")] += 0.5
    with pytest.raises(ValueError, match="n_caged"):
        store_arrays(scene, full)


def test_assemble_needs_an_exact_cover(tmp_path, scene):
    item_files = []
    for a, b in ((0, 5), (5, 9)):
        write_item_file(tmp_path / f"{a}.h5", scene, a, b, fake_items(scene, a, b), KIND_PART, 0.0)
        item_files.append(read_item_file(tmp_path / f"{a}.h5"))
    np.testing.assert_array_equal(assemble(scene, item_files, 0, 9), fake_items(scene, 0, 9))
    with pytest.raises(StoreError, match="do not cover"):
        assemble(scene, item_files)


def test_status_and_merge_of_a_complete_run(tmp_path, scene):
    root = tmp_path / "run"
    write_shards(scene, root, 4)
    st = scan_shards(root)
    assert st.complete and [s.state for s in st.shards] == ["done"] * 4
    merge_shards(root, tmp_path / "m.h5")
    direct = tmp_path / "d.h5"
    write_store(direct, scene, [item_file_in_memory(scene, fake_items(scene, 0, scene.n_items))],
                {}, "test")
    a, b = read_store(tmp_path / "m.h5"), read_store(direct)
    assert set(a.variables) == set(b.variables)
    for f in a.variables:
        np.testing.assert_array_equal(a.variables[f], b.variables[f])


def _truncate(path):
    raw = path.read_bytes()
    path.write_bytes(raw[: len(raw) // 3])


def _other_config_shard(scene, root):
    other = scene_from_dict(tiny(grid={"h": 0.3}))
    write_item_file(root / "shard-0002-of-0004.h5", other, 8, 12, fake_items(other, 8, 12),
                KIND_SHARD, 1.0, chunk=2, n_chunks=4)


def _other_version(scene, root):
    with h5py.File(root / "shard-0001-of-0004.h5", "a") as f:
        f.attrs["sweep_version"] = "0.0.1"


def _duplicate(scene, root):
    (root / "shard-0003-of-0004.h5").write_bytes((root / "shard-0000-of-0004.h5").read_bytes())


def _other_chunking(scene, root):
    write_item_file(root / "shard-0001-of-0002.h5", scene, 8, 16, fake_items(scene, 8, 16),
                KIND_SHARD, 1.0, chunk=1, n_chunks=2)


@pytest.mark.parametrize("damage, chunk, state", [
    pytest.param(lambda s, r: (r / "shard-0002-of-0004.h5").unlink(), 2, "missing", id="missing"),
    pytest.param(lambda s, r: _truncate(r / "shard-0001-of-0004.h5"), 1, "corrupt",
                 id="truncated"),
    pytest.param(_other_config_shard, 2, "mismatched", id="other-config"),
    pytest.param(_other_version, 1, "mismatched", id="other-version"),
    pytest.param(_duplicate, 0, "duplicate", id="duplicate"),
    pytest.param(_other_chunking, None, "mismatched", id="other-chunking"),
])
def test_status_reports_and_merge_refuses(tmp_path, scene, damage, chunk, state):
    root = tmp_path / "run"
    write_shards(scene, root, 4)
    damage(scene, root)
    st = scan_shards(root)
    assert not st.complete
    states = {s.chunk: s.state for s in st.shards}
    if chunk is None:
        assert [s.state for s in st.stray] == [state]
    else:
        assert states[chunk] == state
    out = tmp_path / "m.h5"
    with pytest.raises(StoreError, match=rf"cannot merge .*shard \d+ {state}"):
        merge_shards(root, out)
    assert not out.exists()


def test_manifest_guards_the_run_directory(tmp_path, scene):
    rundir = RunDir(tmp_path / "run")
    ensure_manifest(rundir, scene, 4)
    ensure_manifest(rundir, scene, 4)                       # same sweep: fine
    with pytest.raises(StoreError, match="different number of chunks"):
        ensure_manifest(rundir, scene, 2)
    with pytest.raises(StoreError, match="different config"):
        ensure_manifest(rundir, scene_from_dict(tiny(grid={"h": 0.3})), 4)


def test_status_of_a_directory_that_is_not_a_run(tmp_path):
    with pytest.raises(StoreError, match="not a chunked run directory"):
        scan_shards(tmp_path)
