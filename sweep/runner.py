"""Running a sweep: the whole of it on one machine, or one chunk of it on a cluster node.

Both go through `run_range`: the item range is cut into sub-chunks (`sweep.chunks.sub_ranges`,
never across a geometry group); each finished sub-chunk is written atomically as one *part* file
into a work directory, so a kill loses at most the sub-chunk in flight; a rerun lists the work
directory, computes only what is missing and then assembles the final file (store or shard),
again atomically. Each item's summaries depend on the item alone, so the result is bit-identical
however the work was cut or interrupted.

The compute is `sweep.batch.summarize_cells`, looked up at call time (tests patch it).
"""
from __future__ import annotations

import contextlib
import os
import shutil
import sys
import time
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from . import __version__, batch
from .chunks import chunk_ranges, missing_ranges, sub_ranges
from .scene import Scene
from .store import (KIND_PART, KIND_SHARD, CorruptFile, RunDir, StoreError, assemble,
                    ensure_manifest, read_block, read_json, write_block, write_json_atomic,
                    write_store)

#: Environment variables that may carry the chunk index of an array job, with the index of their
#: first task. SLURM and PBS arrays are written 0..N-1 (as `sweep slurm` does); SGE (`-t 1-N`) and
#: LSF (`name[1-N]`) arrays cannot start at 0, so their index is taken as 1-based.
ARRAY_INDEX_VARS = (("SLURM_ARRAY_TASK_ID", 0), ("PBS_ARRAY_INDEX", 0), ("SGE_TASK_ID", 1),
                    ("LSB_JOBINDEX", 1))
THREADS_VAR = "SLURM_CPUS_PER_TASK"
PART_PREFIX = "items-"


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
        import numba

        if not 1 <= threads <= numba.config.NUMBA_NUM_THREADS:
            raise RunError(f"threads must be between 1 and {numba.config.NUMBA_NUM_THREADS} "
                           f"(this machine's cores), got {threads}")
    return threads


@contextlib.contextmanager
def numba_threads(n: int | None):
    """Set Numba's thread count for the block (None: leave Numba's default, every core), restore
    it after. Per-thread buffers in the kernels are sized by `numba.get_num_threads()`."""
    import numba

    old = numba.get_num_threads()
    if n is not None:
        if not 1 <= n <= numba.config.NUMBA_NUM_THREADS:
            raise RunError(f"threads must be between 1 and {numba.config.NUMBA_NUM_THREADS} "
                           f"(this machine's cores), got {n}")
        numba.set_num_threads(n)
    try:
        yield numba.get_num_threads()
    finally:
        numba.set_num_threads(old)


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


def part_path(parts_dir: Path, start: int, stop: int) -> Path:
    return parts_dir / f"{PART_PREFIX}{start:08d}-{stop:08d}.h5"


def _prepare_parts_dir(parts_dir: Path, scene: Scene, start: int, stop: int) -> list:
    """Create or check the work directory; return the finished, valid parts found in it."""
    manifest = parts_dir / "manifest.json"
    if manifest.exists():
        have = read_json(manifest)
        if (have.get("config_hash"), have.get("sweep_version")) != (scene.config_hash,
                                                                     __version__):
            raise RunError(
                f"{parts_dir} holds partial results of another config or sweep version "
                f"(config {str(have.get('config_hash'))[:12]}, version "
                f"{have.get('sweep_version')}; this run: {scene.config_hash[:12]}, "
                f"{__version__}); delete it or pass --restart")
    else:
        write_json_atomic(manifest, dict(item_start=start, item_stop=stop, **scene.frozen()))
    _remove_stale_tmp(parts_dir)
    blocks = []
    for p in sorted(parts_dir.glob(f"{PART_PREFIX}*.h5")):
        try:
            b = read_block(p, with_data=False)
        except CorruptFile as exc:
            print(f"sweep: discarding unreadable part {p.name}: {exc}", file=sys.stderr)
            p.unlink()
            continue
        if (b.config_hash, b.version) != (scene.config_hash, __version__) or \
                b.start < start or b.stop > stop:
            raise RunError(f"{p}: a part of another sweep in this work directory; delete "
                           f"{parts_dir} or pass --restart")
        blocks.append(b)
    return blocks


def _remove_stale_tmp(directory: Path) -> None:
    """Temporary files of killed writers (`.NAME.tmpPID`) whose process is gone."""
    for p in directory.glob(".*.tmp*"):
        pid = p.name.rsplit(".tmp", 1)[-1]
        if pid.isdigit() and _alive(int(pid)):
            continue
        with contextlib.suppress(OSError):
            p.unlink()


def _alive(pid: int) -> bool:
    try:
        os.kill(pid, 0)
    except ProcessLookupError:
        return False
    except PermissionError:
        return True
    return True


def run_range(scene: Scene, start: int, stop: int, parts_dir: Path, progress: bool = True,
              desc: str | None = None) -> tuple[list, int, float]:
    """Compute every missing sub-chunk of items [start, stop) into `parts_dir`.
    Returns (part blocks, maps computed now, wall seconds of the compute)."""
    blocks = _prepare_parts_dir(parts_dir, scene, start, stop)
    n_w = len(scene.values["w"])
    size = scene.sub_chunk_cells or scene.group_size
    todo = [r for gap in missing_ranges(start, stop, [b.range for b in blocks])
            for r in sub_ranges(gap[0], gap[1], size, scene.group_size)]
    done_maps = (stop - start - sum(b - a for a, b in todo)) * n_w
    computed = 0
    t0 = time.perf_counter()
    bar = _progress_bar(total=(stop - start) * n_w, initial=done_maps, desc=desc or scene.name,
                        enabled=progress)
    try:
        for a, b in todo:
            t = time.perf_counter()
            data = compute_items(scene, a, b)
            seconds = time.perf_counter() - t
            path = part_path(parts_dir, a, b)
            write_block(path, scene, a, b, data, KIND_PART, compute_seconds=seconds)
            blocks.append(read_block(path, with_data=False))
            computed += (b - a) * n_w
            bar.update((b - a) * n_w)
    finally:
        bar.close()
    return blocks, computed, time.perf_counter() - t0


def _progress_bar(total: int, initial: int, desc: str, enabled: bool):
    from tqdm import tqdm

    tty = sys.stderr.isatty()
    return tqdm(total=total, initial=initial, desc=desc, unit="map", unit_scale=False,
                disable=not enabled, mininterval=0.5 if tty else 30.0, file=sys.stderr,
                dynamic_ncols=True)


# ---------------------------------------------------------------------------------------------
# One machine
# ---------------------------------------------------------------------------------------------
def parts_dir_for(out: Path) -> Path:
    """Work directory of a single-machine run: `<RESULTS>.parts/` beside the results."""
    return out.with_name(out.name + ".parts")


def maps_dir_for(out: Path) -> Path:
    return out.with_name(out.name + ".maps")


def run_single(scene: Scene, out: Path, threads: int | None = None, progress: bool = True,
               restart: bool = False, overwrite: bool = False,
               keep_parts: bool = False) -> RunResult:
    """The whole sweep on this machine into the store `out`; resumes from `<out>.parts/`."""
    from .store import read_store

    out = Path(out)
    t_wall = time.perf_counter()
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
            shutil.rmtree(parts_dir_for(out), ignore_errors=True)
        return RunResult(out, scene.n_maps, 0, time.perf_counter() - t_wall,
                         float(view.attrs.get("compute_seconds", 0.0)), already_done=True)
    parts = parts_dir_for(out)
    if restart and parts.exists():
        shutil.rmtree(parts)
    with numba_threads(threads) as n_threads:
        blocks, computed, _ = run_range(scene, 0, scene.n_items, parts, progress)
        saved = save_maps(scene, 0, scene.n_items, maps_dir_for(out))
    compute = sum(b.compute_seconds for b in blocks)
    full = assemble(scene, blocks)
    wall = time.perf_counter() - t_wall
    extra = dict(threads=n_threads)
    if saved:
        extra.update(saved_maps=saved, saved_maps_dir=str(maps_dir_for(out)))
    write_store(out, scene, full, timings=dict(
        wall_seconds=wall, compute_seconds=compute,
        maps_per_second=scene.n_maps / compute if compute > 0 else 0.0),
        created_by="sweep run", extra_attrs=extra)
    if not keep_parts:
        shutil.rmtree(parts, ignore_errors=True)
    return RunResult(out, scene.n_maps, computed, wall, compute)


# ---------------------------------------------------------------------------------------------
# One chunk of a cluster run
# ---------------------------------------------------------------------------------------------
def run_chunk(scene: Scene, out_dir: Path, chunk: int, n_chunks: int, threads: int | None = None,
              progress: bool = True, restart: bool = False) -> RunResult:
    """Shard `chunk` of `n_chunks` into the run directory `out_dir` (resumable like run_single)."""
    t_wall = time.perf_counter()
    if not 0 <= chunk < n_chunks:
        raise RunError(f"chunk index {chunk} outside 0..{n_chunks - 1}")
    try:
        ranges = chunk_ranges(scene.n_items, n_chunks, scene.group_size, scene.group_costs())
    except ValueError as exc:
        raise RunError(f"--chunks {n_chunks}: {exc}") from None
    rundir = RunDir(Path(out_dir))
    ensure_manifest(rundir, scene, n_chunks)
    start, stop = ranges[chunk]
    shard = rundir.shard(chunk, n_chunks)
    n_maps = (stop - start) * len(scene.values["w"])
    if shard.exists():
        try:
            b = read_block(shard, with_data=False)
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
        blocks, computed, _ = run_range(scene, start, stop, parts, progress,
                                        desc=f"{scene.name} {chunk}/{n_chunks}")
        save_maps(scene, start, stop, rundir.maps)
    compute = sum(b.compute_seconds for b in blocks)
    data = assemble(scene, blocks, start, stop)
    write_block(shard, scene, start, stop, data, KIND_SHARD, compute_seconds=compute,
                chunk=chunk, n_chunks=n_chunks)
    shutil.rmtree(parts, ignore_errors=True)
    with contextlib.suppress(OSError):
        parts.parent.rmdir()   # only if no other shard is in progress
    return RunResult(shard, n_maps, computed, time.perf_counter() - t_wall, compute)


# ---------------------------------------------------------------------------------------------
# Full maps for a named subset (outputs.save_maps)
# ---------------------------------------------------------------------------------------------
def map_file_name(point: dict, n_commands: int) -> str:
    name = "map_" + "_".join(f"{k}={point[k]:.12g}"
                             for k in ("l1", "l2", "r1", "r2", "w", "r", "mu"))
    if n_commands > 1:
        name += f"_command={point['command']}"
    return name + ".h5"


def maps_available() -> bool:
    try:
        from . import mapfile, maps  # noqa: F401
    except ImportError:
        return False
    return hasattr(maps, "compute_map") and hasattr(mapfile, "write_map")


def save_maps(scene: Scene, start: int, stop: int, directory: Path) -> list[str]:
    """Compute and write the full map of every `outputs.save_maps` entry whose item lies in
    [start, stop); an existing file is kept (resume) only if it was written for this config
    (its `config_hash` attribute). Returns the file names."""
    wanted = [p for p in scene.save_maps if start <= scene.item_of(p) < stop]
    if not wanted:
        return []
    if not maps_available():
        print("sweep: outputs.save_maps ignored: sweep.maps.compute_map is not available in this "
              "version", file=sys.stderr)
        return []
    from . import mapfile, maps
    from .model import Design, Grid, Part

    names = []
    for p in wanted:
        name = map_file_name(p, len(scene.commands))
        path = Path(directory) / name
        if not _saved_for(path, scene.config_hash):
            m = maps.compute_map(
                Design(**{k: p[k] for k in ("l1", "l2", "r1", "r2", "w")}),
                Part(r=p["r"], mu=p["mu"]), scene.commands[p["command"]], Grid(h=scene.h),
                scene.limits, scene.accuracy, scene.effects)
            path.parent.mkdir(parents=True, exist_ok=True)
            mapfile.write_map(path, m, {"config_hash": scene.config_hash})
        names.append(name)
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
