"""A throw-away single-node SLURM cluster on loopback, for the real-scheduler test.

`LocalSlurm` installs Debian's slurm-wlm and munge when they are missing (apt-get, as root),
writes a minimal slurm.conf into a temporary directory, starts munged (as the munge user),
slurmctld and slurmd in the foreground as our own children, and stops exactly those processes by
their ids (plus any slurmstepd they left behind), then removes the directory. Everything the
cluster uses (config, state, spool, logs, munge socket) lives in that directory, and clients find
the cluster through SLURM_CONF only, so a system-wide SLURM or munge is neither used nor touched.

Whatever stops it from working raises `ClusterError` with the daemon's name and its log lines:
the test fails with them instead of skipping.
"""
from __future__ import annotations

import grp
import os
import pwd
import shutil
import signal
import socket
import subprocess
import tempfile
import time
from pathlib import Path

PACKAGES = ("slurm-wlm", "munge")
BINARIES = ("munged", "slurmctld", "slurmd", "slurmstepd", "sbatch", "scancel", "squeue",
            "sinfo", "scontrol")
#: Process names whose new instances must be gone once the cluster is stopped.
DAEMON_NAMES = ("munged", "slurmctld", "slurmscriptd", "slurmd", "slurmstepd")
LOG_LINES = 40
# Hang guards only (never asserted): how long a daemon may take to come up or go down.
START_TIMEOUT = 60.0
STOP_TIMEOUT = 20.0


class ClusterError(RuntimeError):
    """SLURM could not be installed, started or stopped; the message says which part and why."""


def _sbin(name: str) -> str:
    return shutil.which(name) or shutil.which(name, path="/usr/sbin:/sbin:/usr/bin") or name


def missing_binaries() -> list[str]:
    return [b for b in BINARIES if shutil.which(b, path=os.environ.get("PATH", "") +
                                                ":/usr/sbin:/sbin") is None]


def ensure_installed(log) -> None:
    """apt-get install slurm-wlm and munge if any of their programs is missing."""
    missing = missing_binaries()
    if not missing:
        return
    if os.geteuid() != 0:
        raise ClusterError(f"SLURM is not installed ({', '.join(missing)} missing) and installing "
                           "it needs root: run `make test-slurm` as root, or "
                           f"`apt-get install {' '.join(PACKAGES)}` first")
    if shutil.which("apt-get") is None:
        raise ClusterError(f"SLURM is not installed ({', '.join(missing)} missing) and there is "
                           "no apt-get to install it with (a Debian machine is expected)")
    env = dict(os.environ, DEBIAN_FRONTEND="noninteractive")
    for cmd in (["apt-get", "update"],
                ["apt-get", "install", "-y", "--no-install-recommends", *PACKAGES]):
        log(f"$ {' '.join(cmd)}")
        res = subprocess.run(cmd, env=env, capture_output=True, text=True)
        if res.returncode != 0:
            tail = "\n".join((res.stdout + res.stderr).splitlines()[-LOG_LINES:])
            raise ClusterError(f"`{' '.join(cmd)}` failed with exit code {res.returncode}:\n"
                               f"{tail}")
    still = missing_binaries()
    if still:
        raise ClusterError(f"after installing {' '.join(PACKAGES)}, still missing: "
                           f"{', '.join(still)}")


def processes_named(names=DAEMON_NAMES) -> dict[int, str]:
    """pid -> name of every running process whose name (comm) is one of `names`."""
    found = {}
    for entry in Path("/proc").iterdir():
        if not entry.name.isdigit():
            continue
        try:
            comm = (entry / "comm").read_text().strip()
        except OSError:
            continue
        if comm in names:
            found[int(entry.name)] = comm
    return found


def _free_port() -> int:
    with socket.socket(socket.AF_INET, socket.SOCK_STREAM) as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


def _tail(path: Path, n: int = LOG_LINES) -> str:
    try:
        lines = path.read_text(errors="replace").splitlines()
    except OSError as exc:
        return f"    (no log: {exc})"
    return "\n".join("    " + line for line in lines[-n:]) or "    (log is empty)"


class LocalSlurm:
    """One node, one partition, on 127.0.0.1; use as a context manager (stops on any exit)."""

    def __init__(self, log=print):
        self.log = log
        self.root: Path | None = None
        self.procs: dict[str, subprocess.Popen] = {}
        self.before: dict[int, str] = {}
        self.node = socket.gethostname().split(".")[0]
        self.env: dict[str, str] = {}

    # -----------------------------------------------------------------------------------------
    def __enter__(self) -> LocalSlurm:
        try:
            self.start()
        except BaseException:
            self.stop()
            raise
        return self

    def __exit__(self, *exc) -> None:
        self.stop()

    def start(self) -> None:
        if os.geteuid() != 0:
            raise ClusterError("the real-SLURM test starts slurmctld/slurmd as SlurmUser=root "
                               "and munged as the munge user: it must run as root")
        ensure_installed(self.log)
        self.before = processes_named()
        _become_subreaper()
        # Readable by munged (another user) on the way to its own directory.
        self.root = Path(tempfile.mkdtemp(prefix="sweep-slurm-"))
        self.root.chmod(0o755)
        self._start_munged()
        conf = self._write_conf()
        self.env = dict(os.environ, SLURM_CONF=str(conf))
        for var in [v for v in self.env if v.startswith(("SLURM_", "SBATCH_", "SQUEUE_"))]:
            if var != "SLURM_CONF":       # a surrounding job's settings must not leak in
                del self.env[var]
        self._spawn("slurmctld", [_sbin("slurmctld"), "-D", "-f", str(conf)],
                    self.root / "slurmctld.log")
        self._spawn("slurmd", [_sbin("slurmd"), "-D", "-f", str(conf), "-N", self.node],
                    self.root / "slurmd.log")
        self._wait_node_idle()

    def _start_munged(self) -> None:
        try:
            user = pwd.getpwnam("munge")
            group = grp.getgrgid(user.pw_gid)
        except KeyError:
            raise ClusterError("munge is installed but there is no `munge` user") from None
        mdir = self.root / "munge"
        mdir.mkdir()
        mdir.chmod(0o755)          # munged wants its socket directory searchable by all
        os.chown(mdir, user.pw_uid, user.pw_gid)
        self.munge_socket = mdir / "munge.socket"
        key = Path("/etc/munge/munge.key")
        if not key.exists():
            raise ClusterError(f"munged cannot start: {key} does not exist (the munge package "
                               "creates it on install)")
        cmd = [_sbin("munged"), "--foreground", f"--socket={self.munge_socket}",
               f"--key-file={key}", f"--pid-file={mdir / 'munged.pid'}",
               f"--log-file={mdir / 'munged.log'}", f"--seed-file={mdir / 'munged.seed'}"]
        self._spawn("munged", cmd, mdir / "munged.log", user=user.pw_uid, group=group.gr_gid)
        self._wait(lambda: self.munge_socket.exists(), "munged",
                   f"its socket {self.munge_socket} did not appear")

    def _write_conf(self) -> Path:
        r = self.root
        for d in ("state", "spool"):
            (r / d).mkdir()
        cpus = os.cpu_count() or 1
        text = f"""\
# Written by tests/slurm/local_slurm.py for one test run; removed with its directory.
ClusterName=sweeptest
SlurmctldHost={self.node}(127.0.0.1)
SlurmctldPort={_free_port()}
SlurmdPort={_free_port()}
SlurmUser=root
SlurmdUser=root
AuthType=auth/munge
CredType=cred/munge
AuthInfo=socket={self.munge_socket}
StateSaveLocation={r / 'state'}
SlurmdSpoolDir={r / 'spool'}
SlurmctldPidFile={r / 'slurmctld.pid'}
SlurmdPidFile={r / 'slurmd.pid'}
SlurmctldLogFile={r / 'slurmctld.log'}
SlurmdLogFile={r / 'slurmd.log'}
ProctrackType=proctrack/linuxproc
TaskPlugin=task/none
JobAcctGatherType=jobacct_gather/none
AccountingStorageType=accounting_storage/none
SelectType=select/cons_tres
SelectTypeParameters=CR_Core
SchedulerType=sched/backfill
MpiDefault=none
MailProg=/bin/true
ReturnToService=2
KillWait=30
MinJobAge=600
NodeName={self.node} NodeAddr=127.0.0.1 CPUs={cpus} State=UNKNOWN
PartitionName=debug Nodes={self.node} Default=YES MaxTime=INFINITE State=UP
"""
        conf = r / "slurm.conf"
        conf.write_text(text)
        return conf

    def _spawn(self, name, cmd, logfile, **kwargs) -> None:
        self.log(f"starting {name}: {' '.join(cmd)}")
        stderr = open(self.root / f"{name}.stderr", "wb")
        try:
            # Own session: a Ctrl-C at the terminal reaches pytest, which then stops them.
            self.procs[name] = subprocess.Popen(cmd, stdin=subprocess.DEVNULL, stdout=stderr,
                                                stderr=stderr, start_new_session=True,
                                                **kwargs)
        except OSError as exc:
            raise ClusterError(f"{name} could not be started: {exc}") from None
        finally:
            stderr.close()
        self.logfiles = getattr(self, "logfiles", {})
        self.logfiles[name] = logfile

    def daemon_report(self, name: str) -> str:
        p = self.procs.get(name)
        state = ("not started" if p is None else "running" if p.poll() is None
                 else f"exited with code {p.returncode}")
        return (f"{name} ({state}); last lines of {self.logfiles.get(name)}:\n"
                f"{_tail(self.logfiles[name]) if name in self.logfiles else ''}\n"
                f"  its stderr:\n{_tail(self.root / f'{name}.stderr')}")

    def _wait(self, ready, name, what) -> None:
        deadline = time.monotonic() + START_TIMEOUT
        while not ready():
            for n, p in self.procs.items():
                if p.poll() is not None:
                    raise ClusterError(f"{n} failed to start: {self.daemon_report(n)}")
            if time.monotonic() > deadline:
                raise ClusterError(f"{name} did not come up ({what}): "
                                   f"{self.daemon_report(name)}")
            time.sleep(0.2)

    def _wait_node_idle(self) -> None:
        def idle():
            res = self.run(["sinfo", "-h", "-N", "-o", "%T", "-n", self.node], check=False)
            return res.returncode == 0 and res.stdout.strip() == "idle"

        self._wait(idle, "slurmd", f"node {self.node} never became idle in sinfo; slurmctld: "
                   + self.daemon_report("slurmctld"))

    def _new_stepds(self) -> list[int]:
        return [pid for pid, name in processes_named().items()
                if pid not in self.before and name == "slurmstepd" and not _is_zombie(pid)]

    def _job_processes(self) -> list[int]:
        """Live processes (jobs, clients) started with this cluster's SLURM_CONF, but us."""
        if not self.env.get("SLURM_CONF"):
            return []
        marker = b"SLURM_CONF=" + self.env["SLURM_CONF"].encode()
        found = []
        for entry in Path("/proc").iterdir():
            if not entry.name.isdigit() or int(entry.name) == os.getpid():
                continue
            try:
                if marker in (entry / "environ").read_bytes().split(b"\0") and \
                        not _is_zombie(int(entry.name)):
                    found.append(int(entry.name))
            except OSError:
                continue
        return found

    # -----------------------------------------------------------------------------------------
    def run(self, cmd, check=True, **kwargs) -> subprocess.CompletedProcess:
        """A SLURM client command against this cluster."""
        res = subprocess.run(cmd, env=self.env, capture_output=True, text=True, **kwargs)
        if check and res.returncode != 0:
            raise ClusterError(f"`{' '.join(map(str, cmd))}` failed ({res.returncode}): "
                               f"{res.stderr.strip()}\n{self.daemon_report('slurmctld')}")
        return res

    def job_state(self, job_id: str) -> str:
        """JobState of a job (or array task `ID_I`) from scontrol; '' if unknown."""
        res = self.run(["scontrol", "-o", "show", "job", str(job_id)], check=False)
        for field in res.stdout.split():
            if field.startswith("JobState="):
                return field.split("=", 1)[1]
        return ""

    def stop(self) -> None:
        """Cancel every job, stop the daemons we started (by pid) and whatever slurmstepd they
        left, check none of them runs any more, remove the directory. Safe to call twice."""
        problems = []
        if self.procs.get("slurmctld") and self.procs["slurmctld"].poll() is None:
            self.run(["scancel", "--full", "--user", pwd.getpwuid(os.getuid()).pw_name],
                     check=False, timeout=30)
            deadline = time.monotonic() + STOP_TIMEOUT
            while time.monotonic() < deadline:
                res = self.run(["squeue", "-h", "-o", "%i"], check=False, timeout=30)
                if res.returncode != 0 or not res.stdout.strip():
                    break
                time.sleep(0.3)
        # A finished job's slurmstepd exits on its own a moment later: give it that moment.
        deadline = time.monotonic() + STOP_TIMEOUT
        while time.monotonic() < deadline and self._new_stepds():
            time.sleep(0.2)
        for name in ("slurmd", "slurmctld", "munged"):          # clients first, munge last
            p = self.procs.pop(name, None)
            if p is None or p.poll() is not None:
                continue
            p.send_signal(signal.SIGTERM)
            try:
                p.wait(STOP_TIMEOUT)
            except subprocess.TimeoutExpired:
                problems.append(f"{name} (pid {p.pid}) ignored SIGTERM; killed")
                p.kill()
                p.wait()
        # slurmstepd runs detached from slurmd: any new one is ours.
        for pid in self._new_stepds() + self._job_processes():
            problems.append(f"pid {pid} ({_comm(pid)}) outlived slurmd; killed")
            try:
                os.kill(pid, signal.SIGKILL)
            except ProcessLookupError:
                pass
        deadline = time.monotonic() + STOP_TIMEOUT
        left = {}
        while time.monotonic() < deadline:
            _reap_orphans()
            left = {pid: n for pid, n in processes_named().items() if pid not in self.before}
            left.update({pid: _comm(pid) for pid in self._job_processes()})
            if not left:
                break
            time.sleep(0.2)
        if self.root is not None:
            shutil.rmtree(self.root, ignore_errors=True)
            self.root = None
        if left:
            raise ClusterError("still running after stop: "
                               + ", ".join(f"{n} (pid {p})" for p, n in left.items()))
        for p in problems:
            self.log(f"local_slurm: {p}")


def _become_subreaper() -> None:
    """Orphans of our daemons (slurmstepd detaches from slurmd) become our children, so this
    process can reap them and nothing of the cluster is left even as a zombie."""
    import ctypes

    PR_SET_CHILD_SUBREAPER = 36
    libc = ctypes.CDLL(None, use_errno=True)
    libc.prctl(PR_SET_CHILD_SUBREAPER, 1, 0, 0, 0)


def _reap_orphans() -> None:
    """Collect the exit status of every finished child (called once our daemons are gone)."""
    while True:
        try:
            pid, _ = os.waitpid(-1, os.WNOHANG)
        except ChildProcessError:
            return
        if pid == 0:
            return


def _comm(pid: int) -> str:
    try:
        return Path(f"/proc/{pid}/comm").read_text().strip()
    except OSError:
        return "gone"


def _is_zombie(pid: int) -> bool:
    try:
        stat = Path(f"/proc/{pid}/stat").read_text()
    except OSError:
        return True                                        # gone
    return stat.rsplit(")", 1)[1].split()[0] == "Z"
