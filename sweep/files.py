"""Every file the tool writes goes through here: target checks, the output lock, atomic writes,
clean-up of temporaries left by killed writers, and one-line errors for file-system failures.

- `claim_output(path)` is taken before anything is computed for an output: it refuses a
  directory, a parent that is a file, an existing file (unless `overwrite`), a folder that cannot
  be written, and a second writer (lock file `PATH.lock`, see `OutputLock`); while it is held it
  removes the temporaries of earlier, killed writers of that output.
- `write_bytes_atomic(path, data)` writes under a temporary name in the same directory
  (`.NAME.tmp.HOST.PID`), fsyncs, then renames: a file under its final name is always complete.
  HDF5 (`sweep.storage.h5.atomic_file`), JSON and PNG files are all rendered to bytes in memory
  first, so a full disk is a plain `OSError` here and never an error inside the HDF5 library (which
  crashed the process on ENOSPC).
- `atomic_stream(path)` is the same for a file too large to render in memory first (the results
  store): the HDF5 library writes it to the temporary as it grows, through a `SpooledTemp` that
  never reports a refused write to the library (it carries on in memory) and fails at the end.
- Every `OSError` of a write becomes an `OutputError` whose one-line message names the path and
  says what happened ("no space left on device", "read-only file system", ...).

Locking: a lock file `PATH.lock` holding host, pid and command, made by hard-linking a unique,
complete file to the lock name (open(2)'s advice for NFS; atomic on local disks, every NFS
version and Lustre), with O_EXCL as the fallback where hard links are missing. Not `flock`
(node-local on Lustre mounted `localflock`, an error with `noflock`) nor `fcntl` (needs lockd on
NFSv3, and its release may lag a crashed client). A lock whose holder is on this host and no
longer running is stale and taken over; a holder on another host cannot be checked from here,
so the message names it and the lock file to delete if that job is gone. See docs/sweeps.md,
"Failure modes".
"""
from __future__ import annotations

import contextlib
import errno
import io
import json
import os
import socket
import sys
import time
from pathlib import Path


class StoreError(Exception):
    """A file or directory that is not what an operation needs (CLI exit code 2)."""


class CorruptFile(StoreError):
    """A file with a final name that cannot be read as a complete block/store."""


HOST = socket.gethostname()
TMP_TAG = ".tmp."
LOCK_SUFFIX = ".lock"
#: How often a writer asked to wait (`--wait`) looks at the lock again.
LOCK_POLL_SECONDS = 0.5


class OutputError(OSError):
    """An output that cannot be written (CLI: one line, exit code 2). An OSError, so callers
    that handle file-system failures keep handling it."""


# ---------------------------------------------------------------------------------------------
# Messages
# ---------------------------------------------------------------------------------------------
_REASONS = {
    errno.ENOSPC: "no space left on device",
    errno.EDQUOT: "disk quota exceeded",
    errno.EROFS: "read-only file system",
    errno.EACCES: "permission denied",
    errno.EPERM: "operation not permitted",
    errno.ENOTDIR: "a path component is a file, not a directory",
    errno.EISDIR: "is a directory",
    errno.ENAMETOOLONG: "file name too long",
    errno.EIO: "input/output error",
}


def os_error_message(exc: OSError, path: Path, doing: str = "cannot write") -> str:
    """'PATH: cannot write: no space left on device' - one line, the path the user gave."""
    reason = _REASONS.get(exc.errno) or exc.strerror or type(exc).__name__
    return f"{path}: {doing}: {reason}"


@contextlib.contextmanager
def os_errors_named(path: Path, doing: str = "cannot write"):
    """Turn any OSError of the block into an OutputError naming `path`."""
    try:
        yield
    except OutputError:
        raise
    except OSError as exc:
        err = OutputError(os_error_message(exc, path, doing))
        err.errno = exc.errno           # callers may add advice (e.g. on ENOSPC)
        raise err from None


# ---------------------------------------------------------------------------------------------
# Atomic writes
# ---------------------------------------------------------------------------------------------
def temp_path(path: Path) -> Path:
    """The temporary name of `path` for this process; host and pid say whose it is."""
    return path.with_name(f".{path.name}{TMP_TAG}{HOST}.{os.getpid()}")


def _refuse_file_in_the_way(path: Path) -> None:
    """OutputError if a file stands where a folder of `path` must be: say which one."""
    parent = Path(path).parent
    for p in (parent, *parent.parents):
        if p.exists() and not p.is_dir():
            raise OutputError(f"{path}: {p} is a file, not a directory")
        if p.exists():
            break


def make_parent(path: Path) -> None:
    parent = Path(path).parent
    with os_errors_named(parent, "cannot create folder"):
        _refuse_file_in_the_way(path)
        parent.mkdir(parents=True, exist_ok=True)


def check_output_file(path: str | os.PathLike, overwrite: bool = True) -> None:
    """What `claim_output` refuses for a file, checked without creating anything: a command
    with several outputs checks them all first, so that a refusal of one does not leave the
    folders of another behind (`sweep map --out NEW/x.h5 --plot FILE/x.png` must not leave NEW/
    when FILE is a file)."""
    path = Path(path)
    with os_errors_named(path, "cannot write"):
        _refuse_file_in_the_way(path)
        if path.is_dir():
            raise OutputError(f"{path}: is a directory")
        if path.exists() and not overwrite:
            raise OutputError(f"{path}: exists; pass --overwrite to replace it")


def write_bytes_atomic(path: str | os.PathLike, data: bytes) -> Path:
    """Write `data` to `path` atomically (temporary name, fsync, rename); OutputError on failure,
    with nothing left behind."""
    path = Path(path)
    make_parent(path)
    tmp = temp_path(path)
    try:
        with os_errors_named(path):
            fd = os.open(tmp, os.O_WRONLY | os.O_CREAT | os.O_TRUNC, 0o644)
            try:
                view = memoryview(data)
                while view:
                    view = view[os.write(fd, view):]
                # fsync before the rename: a power cut must not leave a complete name over
                # incomplete data
                os.fsync(fd)
            finally:
                os.close(fd)
            os.replace(tmp, path)
    finally:
        with contextlib.suppress(FileNotFoundError):
            tmp.unlink()
    return path


class SpooledTemp:
    """The temporary of an atomic write that is written piece by piece (by the HDF5 library,
    through h5py's file-object driver) instead of rendered in memory first, so that its memory
    stays flat however large the file (`atomic_stream`). A write or truncation the disk refuses
    (full, quota, ...) never reaches the library as an error (an error there crashed the process
    at exit, as on ENOSPC): from then on the file carries on in memory, its temporary is removed,
    and `commit` raises the refusal as the `OutputError` `write_bytes_atomic` would.

    A seekable binary file as h5py's driver uses it: seek, tell, read, write, truncate, flush."""

    def __init__(self, path: Path):
        self.path = Path(path)
        self.tmp = temp_path(self.path)
        with os_errors_named(self.path):
            self._fd: int | None = os.open(self.tmp, os.O_RDWR | os.O_CREAT | os.O_TRUNC, 0o644)
        self._pos = 0
        self._memory = None               # io.BytesIO, once the disk refused a write
        self.refusal: OSError | None = None

    def _size(self) -> int:
        if self._memory is not None:
            return self._memory.seek(0, os.SEEK_END)
        return os.fstat(self._fd).st_size

    def seek(self, pos: int, whence: int = os.SEEK_SET) -> int:
        base = {os.SEEK_SET: 0, os.SEEK_CUR: self._pos, os.SEEK_END: None}[whence]
        self._pos = (self._size() if base is None else base) + pos
        return self._pos

    def tell(self) -> int:
        return self._pos

    def read(self, size: int = -1) -> bytes:
        size = max(self._size() - self._pos, 0) if size is None or size < 0 else size
        if self._memory is not None:
            with self._memory.getbuffer() as buf:
                data = bytes(buf[self._pos:self._pos + size])
        else:
            data = _pread_all(self._fd, size, self._pos)
        self._pos += len(data)
        return data

    def write(self, data) -> int:
        view = memoryview(data).cast("B")
        if self._memory is None:
            try:
                done = 0
                while done < len(view):
                    done += os.pwrite(self._fd, view[done:], self._pos + done)
            except OSError as exc:
                self._to_memory(exc)
        if self._memory is not None:
            self._memory.seek(self._pos)
            self._memory.write(view)
        self._pos += len(view)
        return len(view)

    def truncate(self, size: int | None = None) -> int:
        size = self._pos if size is None else size
        if self._memory is None:
            try:
                os.ftruncate(self._fd, size)
            except OSError as exc:
                self._to_memory(exc)
        if self._memory is not None:
            grow = size - self._size()
            self._memory.truncate(size)
            if grow > 0:                  # BytesIO.truncate never lengthens: pad with zeros
                self._memory.seek(0, os.SEEK_END)
                self._memory.write(b"\0" * grow)
        return size

    def flush(self) -> None:
        """Nothing is buffered here (every write is a pwrite); `commit` fsyncs."""

    def _to_memory(self, exc: OSError) -> None:
        """The disk refused: carry on in memory from what it holds, and free its space."""
        self.refusal = exc
        self._memory = io.BytesIO(_pread_all(self._fd, os.fstat(self._fd).st_size, 0))
        self.discard()

    def commit(self) -> Path:
        """fsync and rename to the final name; OutputError (nothing left behind) if the disk
        refused a write."""
        if self.refusal is not None:
            self.discard()
            err = OutputError(os_error_message(self.refusal, self.path))
            err.errno = self.refusal.errno
            raise err
        with os_errors_named(self.path):
            os.fsync(self._fd)            # before the rename, as write_bytes_atomic
            os.close(self._fd)
            self._fd = None
            os.replace(self.tmp, self.path)
        return self.path

    def discard(self) -> None:
        """Close and remove the temporary (nothing if already committed or discarded)."""
        if self._fd is not None:
            with contextlib.suppress(OSError):
                os.close(self._fd)
            self._fd = None
            with contextlib.suppress(FileNotFoundError):
                self.tmp.unlink()


def _pread_all(fd: int, size: int, offset: int) -> bytes:
    """Up to `size` bytes from `offset` (fewer only at the end of the file)."""
    chunks, done = [], 0
    while done < size:
        chunk = os.pread(fd, size - done, offset + done)
        if not chunk:
            break
        chunks.append(chunk)
        done += len(chunk)
    return b"".join(chunks)


@contextlib.contextmanager
def atomic_stream(path: str | os.PathLike):
    """Yield a `SpooledTemp` for `path`; rename it into place only if the block succeeds (the
    atomic write of a file too large to render in memory first). OutputError naming `path` on
    any refusal of the disk, with nothing left behind."""
    path = Path(path)
    make_parent(path)
    spool = SpooledTemp(path)
    try:
        yield spool
        spool.commit()
    finally:
        spool.discard()


def _write_new(path: Path, data: bytes, exclusive: bool = False) -> None:
    """Write a small file; with `exclusive`, only if it does not exist (O_EXCL). A failed write
    removes the file (a full disk must not leave an empty lock behind)."""
    flags = os.O_WRONLY | os.O_CREAT | (os.O_EXCL if exclusive else os.O_TRUNC)
    fd = os.open(path, flags, 0o644)
    try:
        try:
            os.write(fd, data)
            os.fsync(fd)
        finally:
            os.close(fd)
    except OSError:
        with contextlib.suppress(OSError):
            path.unlink()
        raise


def write_json_atomic(path: str | os.PathLike, obj) -> Path:
    text = json.dumps(obj, indent=1, sort_keys=True)
    return write_bytes_atomic(path, text.encode())


def text_bytes(text: str) -> bytes:
    """UTF-8 bytes of text for a file; a path with bytes that are not UTF-8 (held as surrogate
    escapes) is written back as those very bytes instead of failing."""
    return text.encode("utf-8", "surrogateescape")


def write_text_atomic(path: str | os.PathLike, text: str) -> Path:
    return write_bytes_atomic(path, text_bytes(text))


def _parse_temp(name: str) -> tuple[str, str, int | None] | None:
    """'.NAME.tmp.HOST.PID' -> (NAME, HOST, PID); the older '.NAME.tmpPID' -> (NAME, '', PID)."""
    if not name.startswith("."):
        return None
    if TMP_TAG in name:
        target, _, rest = name[1:].rpartition(TMP_TAG)
        host, _, pid = rest.rpartition(".")
        return (target, host, int(pid)) if pid.isdigit() and host else None
    target, sep, pid = name[1:].rpartition(".tmp")
    if sep and pid.isdigit():
        return target, "", int(pid)
    return None


def remove_stale_temporaries(directory: Path, names=None, owned: bool = False) -> list[Path]:
    """Remove temporaries of killed writers in `directory` (only those of `names`, if given).

    A temporary is stale when its writer (host, pid) is this host's and no longer running; with
    `owned`, the caller holds the lock of these outputs, so every writer of them is gone,
    whatever host it ran on."""
    removed = []
    directory = Path(directory)
    if not directory.is_dir():
        return removed
    for p in directory.iterdir():
        parsed = _parse_temp(p.name)
        if parsed is None or (names is not None and parsed[0] not in names):
            continue
        target, host, pid = parsed
        if not owned and (host not in ("", HOST) or _alive(pid)):
            continue
        if pid == os.getpid() and host in ("", HOST):
            continue                                    # our own write in progress
        with contextlib.suppress(OSError):
            p.unlink()
            removed.append(p)
    return removed


def _alive(pid: int) -> bool:
    try:
        os.kill(pid, 0)
    except ProcessLookupError:
        return False
    except PermissionError:
        return True
    return True


# ---------------------------------------------------------------------------------------------
# The output lock
# ---------------------------------------------------------------------------------------------
def lock_path(path: Path) -> Path:
    return Path(path).with_name(Path(path).name + LOCK_SUFFIX)


class OutputLock:
    """Exclusive right to write one output (a file, or a shard with its work directory).

    The lock file `PATH.lock` appears atomically with JSON {host, pid, command, since} in it
    (`_try_create`).
    `acquire` refuses at once (OutputError naming the holder) unless `wait`; a lock of a process
    of this host that is gone is removed first."""

    def __init__(self, target: Path, what: str | None = None):
        self.target = Path(target)
        self.path = lock_path(self.target)
        self.what = what or str(self.target)
        self.held = False

    def holder(self) -> dict | None:
        """Who holds the lock (JSON of the lock file), {} if unreadable, None if free."""
        try:
            return json.loads(self.path.read_text() or "{}")
        except FileNotFoundError:
            return None
        except (OSError, ValueError):
            return {}                     # being written right now, or damaged

    def _try_create(self) -> bool:
        """Create the lock file, complete with its holder, in one atomic step (True), or find it
        taken (False). The holder is written to a unique file first and hard-linked to the lock
        name, as open(2) advises for NFS: link(2) is atomic on every NFS version and on Lustre,
        and a lost reply is caught by the link count. Where hard links are not supported the
        lock is created with O_EXCL."""
        info = dict(host=HOST, pid=os.getpid(), command=" ".join(sys.argv),
                    since=time.strftime("%Y-%m-%dT%H:%M:%SZ", time.gmtime()))
        unique = temp_path(self.path)
        try:
            _write_new(unique, json.dumps(info).encode())
            try:
                os.link(unique, self.path)
                return True
            except FileExistsError:
                return os.stat(unique).st_nlink == 2
            except OSError as exc:
                if exc.errno not in (errno.EPERM, errno.EOPNOTSUPP, errno.ENOTSUP, errno.EMLINK):
                    raise
            try:
                _write_new(self.path, json.dumps(info).encode(), exclusive=True)
            except FileExistsError:
                return False
            return True
        finally:
            with contextlib.suppress(FileNotFoundError):
                unique.unlink()

    def _remove_if_stale(self, holder: dict | None) -> bool:
        """Remove the lock if its holder is a dead process of this host. True if removed."""
        if not holder or holder.get("host") != HOST or not isinstance(holder.get("pid"), int):
            return False
        if _alive(holder["pid"]):
            return False
        # Move it aside first, so two processes that both found it stale cannot both remove a
        # lock that a third has just created.
        aside = self.path.with_name(f".{self.path.name}.stale.{HOST}.{os.getpid()}")
        try:
            os.rename(self.path, aside)
        except FileNotFoundError:
            return True
        try:
            moved = json.loads(aside.read_text() or "{}")
        except (OSError, ValueError):
            moved = {}
        if moved == holder:
            aside.unlink()
            return True
        with contextlib.suppress(OSError):      # we moved a fresh lock: put it back
            os.link(aside, self.path)
        aside.unlink()
        return False

    def refusal(self, holder: dict | None) -> str:
        if holder:
            who = (f"pid {holder.get('pid')} on host {holder.get('host')}"
                   + (f", `{holder['command']}`" if holder.get("command") else "")
                   + (f" since {holder['since']}" if holder.get("since") else ""))
        else:
            who = "another process"
        return (f"{self.what} is being written by {who}; wait for it (or pass --wait), or "
                f"delete {self.path} if that process is gone")

    def acquire(self, wait: bool = False) -> "OutputLock":
        make_parent(self.path)
        with os_errors_named(self.target):
            while True:
                if self._try_create():
                    self.held = True
                    return self
                holder = self.holder()
                if holder is None or self._remove_if_stale(holder):
                    continue
                if not wait:
                    raise OutputError(self.refusal(holder))
                time.sleep(LOCK_POLL_SECONDS)

    def release(self) -> None:
        if self.held:
            with contextlib.suppress(OSError):
                self.path.unlink()
            self.held = False

    def __enter__(self):
        return self

    def __exit__(self, *exc):
        self.release()


@contextlib.contextmanager
def claim_output(path: str | os.PathLike, *, overwrite: bool = True, directory: bool = False,
                 wait: bool = False, what: str | None = None, lock: Path | None = None):
    """Check and lock an output before any work; yield the lock; release it at the end.

    `directory`: the output is a run directory (it may exist). Otherwise it is a file: refused if
    it is a directory, or exists and not `overwrite`. While held, temporaries of killed writers
    of the output are removed. `lock` names the locked object when it is not `path` itself
    (one shard of a run directory)."""
    path = Path(path)
    if directory:
        if path.exists() and not path.is_dir():
            raise OutputError(f"{path}: is a file, not a directory")
        make_parent(path / "x")
    else:
        if path.is_dir():
            raise OutputError(f"{path}: is a directory")
        make_parent(path)
        if path.exists() and not overwrite:
            raise OutputError(f"{path}: exists; pass --overwrite to replace it")
    held = OutputLock(lock or path, what=what).acquire(wait=wait)
    try:
        if not directory and path.exists() and not overwrite:
            # created by the writer we waited for
            raise OutputError(f"{path}: exists; pass --overwrite to replace it")
        target = lock or path
        remove_stale_temporaries(target.parent, names={target.name}, owned=True)
        # a lock's temporary may be a live rival's attempt to take it: only dead ones go
        remove_stale_temporaries(target.parent, names={held.path.name})
        yield held
    finally:
        held.release()
