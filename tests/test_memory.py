"""The memory check counts every array a run holds (issue P13), and merging stays flat."""
import numpy as np
import pytest
from click.testing import CliRunner

import sweep.grid
import sweep.runs.rundir
from sweep.compute.batch import manipulation_cells
from sweep.cli import main
from sweep.kernels.records import new_finger_arrays, new_force_arrays, new_outcome_arrays
from sweep.compute.manipulation import ManipulationChunk
from sweep.grid import BYTES_PER_POINT, FORCE_BYTES_PER_POINT, map_bytes_per_point
from sweep.model import Accuracy, Effects, Limits
from sweep.config.parse import scene_from_dict
from sweep.storage.store import write_bytes
from sweep_cases import tiny, write_config


def nbytes(record) -> int:
    return sum(a.nbytes for a in record)


def test_bytes_per_point_are_those_of_the_arrays_a_map_allocates():
    ny, nx = 7, 11
    fingers, outs = new_finger_arrays(2, ny, nx), new_outcome_arrays(ny, nx)
    stack = np.empty(ny * nx, dtype=np.int64)          # the trajectory stack (maps.compute_map)
    assert (nbytes(fingers) + nbytes(outs) + stack.nbytes) / (ny * nx) == BYTES_PER_POINT
    assert nbytes(new_force_arrays(ny, nx)) / (ny * nx) == FORCE_BYTES_PER_POINT
    assert map_bytes_per_point(forces=True) == BYTES_PER_POINT + FORCE_BYTES_PER_POINT
    assert map_bytes_per_point(forces=True, written=True) == 2 * map_bytes_per_point(True)


def test_a_sweep_counts_its_manipulation_buffers_and_results():
    plain = scene_from_dict(tiny())
    manip = scene_from_dict(tiny(outputs={"manipulation": True}))
    assert manip.cell_bytes() > plain.cell_bytes() > 0
    assert manip.held_bytes() > plain.held_bytes() >= 2 * plain.n_maps * 8
    assert plain.memory_bytes(4) == 4 * plain.cell_bytes() + plain.held_bytes()


@pytest.fixture
def little_memory(monkeypatch):
    monkeypatch.setattr(sweep.grid, "available_memory", lambda: 1 << 10)   # 1 KiB free


def test_a_run_that_does_not_fit_is_refused_before_anything_is_written(tmp_path,
                                                                       little_memory):
    cfg = write_config(tmp_path / "c.yaml", tiny())
    for args in (["run", cfg, "--out", tmp_path / "new" / "a.h5", "--no-progress"],
                 ["run", cfg, "--out", tmp_path / "runs", "--chunks", "2", "--chunk", "0",
                  "--no-progress"],
                 ["map", "--l1", "2", "--l2", "1.6", "--r1", "0.2", "--r2", "0.14", "--w",
                  "0.8", "--r", "0.4", "--mu", "0.4", "--h", "0.05", "--forces", "--out",
                  tmp_path / "m.h5"]):
        res = CliRunner().invoke(main, [str(a) for a in args])
        lines = [ln for ln in res.output.splitlines() if ln.strip()]
        assert res.exit_code == 2 and len(lines) == 1, res.output
        assert "GiB" in lines[0] and ("free" in lines[0] or "fit" in lines[0])
    assert sorted(p.name for p in tmp_path.iterdir()) == ["c.yaml"]


def test_what_a_merge_holds_does_not_grow_with_the_designs():
    """A merge holds one shard and one range of a part's poses at a time (store.write_bytes):
    more l1 values inside the range (the same geometry groups, the same pose lattices) change
    nothing for shards of the same size, while the whole sweep's results grow."""
    small = scene_from_dict(tiny(outputs={"manipulation": True}))
    big = scene_from_dict(tiny(designs={"l1": [0.8, 0.9, 1.0, 1.1, 1.2]},
                               outputs={"manipulation": True}))
    assert big.n_maps == 2.5 * small.n_maps and big.group_size == small.group_size
    assert write_bytes(big, 8) == write_bytes(small, 8) > write_bytes(small, 4)
    assert big.held_bytes() > small.held_bytes()


def test_a_merge_that_does_not_fit_is_refused_before_anything_is_written(tmp_path,
                                                                         monkeypatch):
    cfg = write_config(tmp_path / "c.yaml", tiny())
    for k in range(2):
        res = CliRunner().invoke(main, ["run", str(cfg), "--out", str(tmp_path / "runs"),
                                        "--chunks", "2", "--chunk", str(k), "--no-progress"])
        assert res.exit_code == 0, res.output
    monkeypatch.setattr(sweep.grid, "available_memory", lambda: 1 << 10)
    res = CliRunner().invoke(main, ["merge", str(tmp_path / "runs"), "--out",
                                    str(tmp_path / "m.h5")])
    lines = [ln for ln in res.output.splitlines() if ln.strip()]
    assert res.exit_code == 2 and len(lines) == 1, res.output
    assert "GiB" in lines[0] and "free" in lines[0]
    assert sorted(p.name for p in tmp_path.iterdir()) == ["c.yaml", "runs"]


def test_streamed_merge_of_chunks_equals_the_one_pass_merge():
    """ManipulationChunk.merge_stream (one item file at a time, what the store's assembly uses)
    gives the hulls, values and usage of merge_all and of the whole run at once."""
    cells = np.array([[1.4, 0.8, 0.12, 0.10, 0.4, 0.4], [1.4, 0.8, 0.16, 0.14, 0.4, 0.4],
                      [1.2, 1.2, 0.08, 0.06, 0.4, 0.4], [1.0, 0.8, 0.2, 0.1, 0.8, 0.4]])
    widths = np.array([0.0, 0.4])
    keys = np.array([[0, 0], [0, 0], [0, 0], [1, 0]])
    args = (widths, 0.1, Limits(), Accuracy(), Effects())
    ncol = np.full(4, 25)
    _, whole = manipulation_cells(cells, *args, np.arange(4), keys, ncol)
    chunks = [manipulation_cells(cells[a:b], *args, np.arange(a, b), keys[a:b], ncol[a:b])[1]
              for a, b in ((0, 1), (1, 3), (3, 4))]
    streamed = ManipulationChunk.merge_stream(iter(chunks))
    at_once = ManipulationChunk.merge_all(chunks)
    assert (streamed.start, streamed.stop) == (0, 4)
    np.testing.assert_array_equal(streamed.a_metric, whole.a_metric)
    assert sorted(streamed.parts) == sorted(whole.parts) == [(0, 0), (1, 0)]
    for key in whole.parts:
        for name in ("all", "uncrossed"):
            s, w, o = (c.parts[key][name] for c in (streamed, whole, at_once))
            np.testing.assert_array_equal(s.pose_ids, w.pose_ids)
            np.testing.assert_array_equal(s.values(), w.values())
            np.testing.assert_array_equal(s.values(), o.values())
            np.testing.assert_array_equal(s.parameter_usage(), w.parameter_usage())
    with pytest.raises(ValueError):
        ManipulationChunk.merge_stream([chunks[0], chunks[2]])      # not adjacent
