"""Running a sweep: the whole of it on one machine, or one chunk of it on a cluster node.

Both go through `run_range`: the item range is cut into sub-chunks
(`sweep.config.chunks.sub_ranges`, never across a geometry group); each finished sub-chunk is
written atomically as one *part* file into a work directory, so a kill loses at most the sub-chunk
in flight; a rerun lists the work directory, computes only what is missing and then assembles the
final file (store or shard), again atomically. Each item's summaries depend on the item alone, so
the result is bit-identical however the work was cut or interrupted.

The compute is `sweep.compute.batch.summarize_cells`, looked up at call time (tests patch it).
"""
from __future__ import annotations

import collections
import concurrent.futures
import contextlib
import os
import shutil
import sys
import time
from dataclasses import dataclass
from pathlib import Path

import numba
import numpy as np

from .. import __version__, grid
from ..compute import batch, maps, warm
from ..compute.threads import check_threads, numba_threads
from ..storage import mapfile
from ..config.chunks import chunk_ranges, missing_ranges, sub_ranges
from ..model import Design, Grid, Part
from ..files import claim_output, remove_stale_temporaries
from .rundir import (RunDir, SingleRun, ensure_manifest, map_file_name, part_path,
                     prepare_parts_dir)
from ..config.scene import Scene
from ..storage.itemfile import (
    KIND_PART, KIND_SHARD, assemble, assemble_manipulation, read_item_file, write_item_file,
)
from ..storage.store import CorruptFile, StoreError, read_store, write_store

#: Environment variables that may carry the chunk index of an array job, with the index of their
#: first task. SLURM and PBS arrays are written 0..N-1 (as `sweep slurm` does); SGE (`-t 1-N`) and
#: LSF (`name[1-N]`) arrays cannot start at 0, so their index is taken as 1-based.
ARRAY_INDEX_VARS = (("SLURM_ARRAY_TASK_ID", 0), ("PBS_ARRAY_INDEX", 0), ("SGE_TASK_ID", 1),
                    ("LSB_JOBINDEX", 1))
THREADS_VAR = "SLURM_CPUS_PER_TASK"


class RunError(StoreError):
    """A run that cannot start (bad chunk index, foreign work directory...): CLI exit code 2."""


@dataclass
class RunResult:
    path: Path
    n_maps: int            # maps of the range this run is responsible for
    computed_maps: int     # maps computed by this invocation (the rest were on disk)
    wall_seconds: float
    compute_seconds: float  # summed over all parts, including earlier invocations
    already_done: bool = False


# ---------------------------------------------------------------------------------------------
# Environment: chunk index and threads (read in exactly one place each)
# ---------------------------------------------------------------------------------------------
def chunk_index_from_env(environ=None) -> tuple[int, str] | None:
    """(chunk index, variable name) from the first array-job variable that is set, else None."""
    environ = os.environ if environ is None else environ
    for var, first in ARRAY_INDEX_VARS:
        raw = environ.get(var, "").strip()
        if not raw or raw.lower() == "undefined":
            continue
        try:
            value = int(raw)
        except ValueError:
            raise RunError(f"{var}={raw!r} is not an array index") from None
        if var == "LSB_JOBINDEX" and value == 0:   # LSF sets 0 outside array jobs
            continue
        return value - first, var
    return None


def resolve_threads(threads: int | None, environ=None) -> int | None:
    """--threads, else SLURM_CPUS_PER_TASK, else None (Numba's default: every core)."""
    environ = os.environ if environ is None else environ
    if threads is None and environ.get(THREADS_VAR, "").strip():
        raw = environ[THREADS_VAR].strip()
        try:
            threads = int(raw)
        except ValueError:
            raise RunError(f"{THREADS_VAR}={raw!r} is not a number of threads") from None
    if threads is not None:
        check_threads(threads)
    return threads


def check_run_memory(scene: Scene, threads: int | None) -> None:
    """Refuse a run whose arrays (Scene.memory_bytes: every thread's largest cell, the results
    and the manipulation reductions) would not fit in this machine's free memory; `threads`
    None means Numba's default (every core)."""
    if threads is None:
        import numba

        threads = numba.get_num_threads()
    gib = 1024**3
    grid.check_memory_need(scene.memory_bytes(threads),
                           f"the run ({threads} threads x {scene.cell_bytes() / gib:.2f} GiB "
                           f"for the largest cell, {scene.held_bytes() / gib:.2f} GiB of "
                           f"results)", "use fewer --threads or a larger grid.h")


# ---------------------------------------------------------------------------------------------
# Compute
# ---------------------------------------------------------------------------------------------
def compute_items(scene: Scene, start: int, stop: int) -> np.ndarray:
    """Summaries of items [start, stop): float64 (n, n_w, n_fields), one kernel call per run of
    items under the same command."""
    cells, cmd = scene.cells(start, stop)
    widths = scene.widths
    out = np.empty((stop - start, widths.size, len(batch.SUMMARY_FIELDS)), dtype=np.float64)
    i = 0
    while i < cmd.size:
        j = i
        while j < cmd.size and cmd[j] == cmd[i]:
            j += 1
        res = np.asarray(batch.summarize_cells(
            np.ascontiguousarray(cells[i:j]), widths, scene.commands[int(cmd[i])], scene.h,
            scene.limits, scene.accuracy, scene.effects), dtype=np.float64)
        if res.shape != (j - i,) + out.shape[1:]:
            raise RuntimeError(f"summarize_cells returned shape {res.shape} for {j - i} cells "
                               f"and {widths.size} widths")
        out[i:j] = res
        i = j
    return out


def compute_items_with_manipulation(scene: Scene, start: int, stop: int):
    """Summaries and manipulation data (MODEL 10, Scenario C too when the scene asks for it) of
    items [start, stop): the scene has one command (scene validation), so one kernel call."""
    cells, _ = scene.cells(start, stop)
    r_index = scene.part_keys(start, stop)[:, 0]
    return batch.manipulation_cells(
        cells, scene.widths, scene.h, scene.limits, scene.accuracy, scene.effects,
        np.arange(start, stop, dtype=np.int64), scene.part_keys(start, stop),
        scene.lattice_columns()[r_index], command=scene.commands[0],
        mu_low=scene.scenario_c_mu_low)


#: Sub-chunks in flight at once: while one's kernels run, another's single-threaded work (its
#: manipulation reductions' Python side, reading and writing files) fills the cores
#: (docs/performance-log.md, "Sub-chunks in flight").
IN_FLIGHT = 2


def compute_sub_chunk(scene: Scene, start: int, stop: int, threads: int):
    """(summaries, manipulation data or None) of items [start, stop) on `threads` kernel
    threads (Numba's thread count is the calling thread's own: set here, in the worker)."""
    with numba_threads(threads):
        if scene.manipulation:
            return compute_items_with_manipulation(scene, start, stop)
        return compute_items(scene, start, stop), None


def run_range(scene: Scene, start: int, stop: int, parts_dir: Path, progress: bool = True,
              desc: str | None = None) -> tuple[list, int, float]:
    """Compute every missing sub-chunk of items [start, stop) into `parts_dir`, IN_FLIGHT at a
    time, written in order as each finishes. Returns (part files, maps computed now, wall
    seconds of the compute). A part file's compute seconds are the wall time since the previous
    part file was written (their sum is the compute's wall time; overlapping sub-chunks would
    count twice)."""
    item_files = prepare_parts_dir(parts_dir, scene, start, stop)
    n_w = len(scene.values["w"])
    size = scene.sub_chunk_cells or scene.group_size
    todo = [r for gap in missing_ranges(start, stop, [b.range for b in item_files])
            for r in sub_ranges(gap[0], gap[1], size, scene.group_size)]
    done_maps = (stop - start - sum(b - a for a, b in todo)) * n_w
    if todo:  # (before the progress bar: its rate and ETA are the computation's alone)
        warm.ensure_compiled()
    computed = 0
    t0 = time.perf_counter()
    bar = _progress_bar(total=(stop - start) * n_w, initial=done_maps, desc=desc or scene.name,
                        enabled=progress)
    threads = numba.get_num_threads()
    pending = iter(todo)
    running: collections.deque = collections.deque()
    pool = concurrent.futures.ThreadPoolExecutor(max_workers=IN_FLIGHT)

    def start_next():
        for a, b in pending:
            running.append((a, b, pool.submit(compute_sub_chunk, scene, a, b, threads)))
            return

    try:
        for _ in range(IN_FLIGHT):
            start_next()
        last = time.perf_counter()
        while running:
            a, b, future = running.popleft()
            data, manipulation = future.result()
            start_next()
            now = time.perf_counter()
            path = part_path(parts_dir, a, b)
            write_item_file(path, scene, a, b, data, KIND_PART, compute_seconds=now - last,
                            manipulation=manipulation)
            last = now
            item_files.append(read_item_file(path, with_data=False))
            computed += (b - a) * n_w
            bar.update((b - a) * n_w)
    finally:
        for _, _, future in running:   # (on an error or an interrupt: no new sub-chunk starts)
            future.cancel()
        pool.shutdown(wait=True)
        bar.close()
    return item_files, computed, time.perf_counter() - t0


def _progress_bar(total: int, initial: int, desc: str, enabled: bool):
    from tqdm import tqdm

    tty = sys.stderr.isatty()
    return tqdm(total=total, initial=initial, desc=desc, unit="map", unit_scale=False,
                disable=not enabled, mininterval=0.5 if tty else 30.0, file=sys.stderr,
                dynamic_ncols=True)


# ---------------------------------------------------------------------------------------------
# One machine
# ---------------------------------------------------------------------------------------------
def run_single(scene: Scene, out: Path, threads: int | None = None, progress: bool = True,
               restart: bool = False, overwrite: bool = False,
               keep_parts: bool = False, wait: bool = False) -> RunResult:
    """The whole sweep on this machine into the store `out`; resumes from `<out>.parts/`.
    Holds the lock of `out` throughout: a second run to the same store is refused at once
    (`sweep.files.OutputError`) or, with `wait`, waits for the first."""
    out = Path(out)
    t_wall = time.perf_counter()
    paths = SingleRun(out)
    check_run_memory(scene, threads)
    with claim_output(out, overwrite=True, wait=wait):
        if out.exists() and not overwrite:
            try:
                view = read_store(out)
            except StoreError as exc:
                raise RunError(f"{out} exists and is not a results store of this sweep ({exc}); "
                               "pass --overwrite to replace it") from None
            same = (view.attrs.get("config_hash"), view.attrs.get("sweep_version")) == \
                (scene.config_hash, __version__)
            if not same:
                raise RunError(f"{out} holds the results of another config or sweep version; "
                               "pass --overwrite to replace it or choose another --out")
            if not keep_parts:   # left over if a kill came between the store's rename and cleanup
                shutil.rmtree(paths.parts, ignore_errors=True)
            return RunResult(out, scene.n_maps, 0, time.perf_counter() - t_wall,
                             float(view.attrs.get("compute_seconds", 0.0)), already_done=True)
        if restart and paths.parts.exists():
            shutil.rmtree(paths.parts)
        with numba_threads(threads) as n_threads:
            item_files, computed, _ = run_range(scene, 0, scene.n_items, paths.parts, progress)
            saved = save_maps(scene, 0, scene.n_items, paths.maps)
        compute = sum(b.compute_seconds for b in item_files)
        wall = time.perf_counter() - t_wall
        extra = dict(threads=n_threads)
        if saved:
            extra.update(saved_maps=saved, saved_maps_dir=str(paths.maps))
        write_store(out, scene, item_files, timings=dict(
            wall_seconds=wall, compute_seconds=compute,
            maps_per_second=scene.n_maps / compute if compute > 0 else 0.0),
            created_by="sweep run", extra_attrs=extra)
        if not keep_parts:
            shutil.rmtree(paths.parts, ignore_errors=True)
    return RunResult(out, scene.n_maps, computed, wall, compute)


# ---------------------------------------------------------------------------------------------
# One chunk of a cluster run
# ---------------------------------------------------------------------------------------------
def run_chunk(scene: Scene, out_dir: Path, chunk: int, n_chunks: int, threads: int | None = None,
              progress: bool = True, restart: bool = False, wait: bool = False) -> RunResult:
    """Shard `chunk` of `n_chunks` into the run directory `out_dir` (resumable and locked like
    run_single; the lock is the shard's, so other chunks run alongside)."""
    t_wall = time.perf_counter()
    if not 0 <= chunk < n_chunks:
        raise RunError(f"chunk index {chunk} outside 0..{n_chunks - 1}")
    try:
        ranges = chunk_ranges(scene.n_items, n_chunks, scene.group_size, scene.group_costs())
    except ValueError as exc:
        raise RunError(f"--chunks {n_chunks}: {exc}") from None
    check_run_memory(scene, threads)
    rundir = RunDir(Path(out_dir))
    ensure_manifest(rundir, scene, n_chunks)
    start, stop = ranges[chunk]
    shard = rundir.shard(chunk, n_chunks)
    n_maps = (stop - start) * len(scene.values["w"])
    # The shard's lock covers its work directory and its saved maps too.
    with claim_output(rundir.root, directory=True, lock=shard, wait=wait,
                      what=f"chunk {chunk} of {rundir.root}"):
        if shard.exists():
            try:
                b = read_item_file(shard, with_data=False)
                if (b.config_hash, b.version, b.range) == (scene.config_hash, __version__,
                                                           (start, stop)):
                    return RunResult(shard, n_maps, 0, time.perf_counter() - t_wall,
                                     b.compute_seconds, already_done=True)
            except CorruptFile:
                pass
            print(f"sweep: replacing unusable shard {shard.name}", file=sys.stderr)
        parts = rundir.parts(chunk, n_chunks)
        if restart and parts.exists():
            shutil.rmtree(parts)
        with numba_threads(threads):
            item_files, computed, _ = run_range(scene, start, stop, parts, progress,
                                            desc=f"{scene.name} {chunk}/{n_chunks}")
            save_maps(scene, start, stop, rundir.maps)
        compute = sum(b.compute_seconds for b in item_files)
        data = assemble(scene, item_files, start, stop)
        write_item_file(shard, scene, start, stop, data, KIND_SHARD, compute_seconds=compute,
                    chunk=chunk, n_chunks=n_chunks,
                    manipulation=assemble_manipulation(scene, item_files, start, stop))
        shutil.rmtree(parts, ignore_errors=True)
        with contextlib.suppress(OSError):
            parts.parent.rmdir()   # only if no other shard is in progress
    return RunResult(shard, n_maps, computed, time.perf_counter() - t_wall, compute)


# ---------------------------------------------------------------------------------------------
# Full maps for a named subset (outputs.save_maps)
# ---------------------------------------------------------------------------------------------
def save_maps(scene: Scene, start: int, stop: int, directory: Path) -> list[str]:
    """Compute and write the full map of every `outputs.save_maps` entry whose item lies in
    [start, stop); an existing file is kept (resume) only if it was written for this config
    (its `config_hash` attribute). Returns the file names."""
    wanted = [p for p in scene.save_maps if start <= scene.item_of(p) < stop]
    if not wanted:
        return []
    names = [map_file_name(p, len(scene.commands)) for p in wanted]
    # the caller holds the lock that covers these maps: their temporaries are killed writers'
    remove_stale_temporaries(Path(directory), names=set(names), owned=True)
    for p, name in zip(wanted, names):
        path = Path(directory) / name
        if not _saved_for(path, scene.config_hash):
            m = maps.compute_map(
                Design(**{k: p[k] for k in ("l1", "l2", "r1", "r2", "w")}),
                Part(r=p["r"], mu=p["mu"]), scene.commands[p["command"]], Grid(h=scene.h),
                scene.limits, scene.accuracy, scene.effects, outputs=scene.outputs)
            mapfile.write_map(path, m, {"config_hash": scene.config_hash})
    return names


def _saved_for(path: Path, config_hash: str) -> bool:
    """The map file exists, is readable and was written for this config."""
    import h5py

    try:
        with h5py.File(path, "r") as f:
            stored = f.attrs.get("config_hash", "")
    except (OSError, KeyError):
        return False
    if isinstance(stored, bytes):
        stored = stored.decode()
    return stored == config_hash
