"""An operating-system boundary for running untrusted Python: bubblewrap with an allow-list seccomp filter.

Used for xacro documents sent to the server (xacro's `${...}` is Python, so an upload is code).
`run()` runs `python -I -S program args`:

- in new user, PID, network, IPC and UTS namespaces (`bwrap --unshare-*`): it sees no other process,
  so it can signal, trace or `pidfd_open` none, has no network, and its host name is HOSTNAME;
- as uid and gid NOBODY in its user namespace, with every capability dropped and `no_new_privs`.
  Where the kernel refuses a user namespace to a root server, it runs as the host's `nobody` instead
  (`setpriv`); a server that is not root then cannot confine anything (Unavailable);
- on an empty root holding, read-only, only what expansion needs: the interpreter, its standard
  library (its site-packages hidden) and extension modules, the shared libraries they link to (as
  `ldd` finds them), the packages the caller names (at SITE, not the venv), the program and the
  caller's folders. /dev holds null, zero and urandom only; there is no /usr, /etc, /proc or /tmp;
- behind a seccomp allow-list (libseccomp through pyseccomp): the system calls a Python expansion
  makes; every other one, through ctypes too, fails with EPERM (processes, threads, sockets, uname,
  sleeps, mounts, namespaces, ptrace...);
- in its own session (no terminal injection), killed with its parent (`--die-with-parent`), and with
  its whole process group past the caller's wall-clock timeout;
- at most one sandbox per core at once (SLOTS): a run waits for a free core before its timeout starts.

CPU, memory and file-size limits are rlimits the program sets before reading any input, and the
caller reads its output with a cap. `unavailable()` says why a machine cannot provide this (no
bwrap, no libseccomp, namespaces refused), so callers can refuse instead.
"""
from __future__ import annotations

import errno
import functools
import glob
import os
import pwd
import re
import shutil
import signal
import subprocess
import sys
import sysconfig
import tempfile
import termios
import threading
from collections.abc import Iterable, Mapping
from importlib.util import find_spec
from pathlib import Path
from typing import Any

from urdfkb.pipeline.errors import UrdfkbError
from urdfkb.settings import MAX_ERROR

HOSTNAME = "sandbox"  # the host name inside: the host's never shows
NOBODY = 65534  # the uid and gid inside
PROGRAM_DIR = "/urdfkb"  # where the program is mounted inside
SITE = "/site"  # where the packages named to run() are mounted inside (on sys.path)
DEVICES = ("/dev/null", "/dev/zero", "/dev/urandom")  # the whole of /dev inside
# `python -I -S -B -c BOOT program args`: no site-packages, but the packages mounted at SITE.
BOOT = f"import runpy, sys; sys.path.append({SITE!r}); del sys.argv[0]; runpy.run_path(sys.argv[0], run_name='__main__')"
# The system calls a Python expansion makes (found with strace): the loader's and the interpreter's start,
# memory, reading the read-only files, its output, its limits and priority; every other fails with EPERM
# (clone3 with ENOSYS), and ioctl answers TCGETS only (isatty). No process, thread, socket, pipe,
# signal or sleep: a xacro that sleeps fails at once.
ALLOWED = ("execve", "arch_prctl", "set_tid_address", "set_robust_list", "rseq", "getrandom", "sysinfo",
           "rt_sigaction", "rt_sigprocmask", "rt_sigreturn", "brk", "mmap", "munmap", "mprotect", "mremap", "madvise",
           "openat", "read", "pread64", "readv", "write", "writev", "lseek", "close", "fcntl", "newfstatat", "fstat",
           "stat", "lstat", "statx", "getdents64", "readlink", "readlinkat", "access", "faccessat", "faccessat2",
           "getcwd", "prlimit64", "getrlimit", "setrlimit", "getpriority", "setpriority", "getuid", "geteuid",
           "getgid", "getegid", "getpid", "gettid", "exit", "exit_group",
           "wait4")  # bwrap's init (PID 1 inside, reaping the program) runs under the filter too
# Allowed too where setpriv runs inside (it starts under the filter; without capabilities they change nothing).
SETPRIV_CALLS = ("capget", "capset", "prctl", "getresuid", "getresgid", "setgroups", "setresuid", "setresgid")
# At most one sandbox per core at once; the wait for a slot is not counted in run()'s timeout.
SLOTS = threading.BoundedSemaphore(len(os.sched_getaffinity(0)))


class Unavailable(UrdfkbError, RuntimeError):
    """This machine cannot confine a program (the message says what is missing); the server refuses (403)
    what it would have to confine."""

    status = 403


def _bwrap() -> str:
    path = shutil.which("bwrap")
    if path is None:
        raise Unavailable("bubblewrap (bwrap) is not installed (Debian: apt-get install bubblewrap)")
    return path


def _seccomp_filter(extra: Iterable[str] = ()) -> bytes:
    """The compiled BPF program allowing ALLOWED and `extra` only (Unavailable without libseccomp)."""
    try:
        import pyseccomp as seccomp
    except (ImportError, OSError, TypeError) as e:  # pyseccomp raises on import when libseccomp is missing
        raise Unavailable(f"libseccomp is not usable through pyseccomp ({e})") from None
    rules = seccomp.SyscallFilter(defaction=seccomp.ERRNO(errno.EPERM))
    add_rules(rules, seccomp.ALLOW, (*ALLOWED, *extra))
    rules.add_rule(seccomp.ALLOW, "ioctl", seccomp.Arg(1, seccomp.EQ, termios.TCGETS))
    rules.add_rule(seccomp.ERRNO(errno.ENOSYS), "clone3")
    with tempfile.TemporaryFile() as f:
        rules.export_bpf(f)
        f.seek(0)
        return f.read()


def add_rules(rules: Any, action: Any, calls: Iterable[str]) -> None:
    """Give each of the system calls `calls` that this architecture has `action` in the pyseccomp filter `rules`."""
    for name in calls:
        try:
            rules.add_rule(action, name)
        except (OSError, ValueError, RuntimeError):  # a syscall this architecture does not have
            pass


def _interpreter() -> str:
    """The Python binary itself (a venv's python is a link to it)."""
    return os.path.realpath(getattr(sys, "_base_executable", None) or sys.executable)


def _base_paths() -> dict[str, str]:
    """The base Python installation's paths (not a venv's): its standard library and site-packages."""
    return sysconfig.get_paths(vars={"base": sys.base_prefix, "platbase": sys.base_exec_prefix})


@functools.lru_cache(maxsize=1)
def _runtime() -> dict[str, str]:
    """Mounts (inside path -> host path) of the Python runtime at its own paths: the interpreter, its
    standard library with its extension modules, and the shared libraries they link to."""
    paths = _base_paths()
    mounts = {_interpreter(): _interpreter()}
    for lib in (paths["stdlib"], paths["platstdlib"]):
        mounts[lib] = os.path.realpath(lib)
    dynload = glob.glob(os.path.join(paths["platstdlib"], "lib-dynload", "*.so"))
    for lib in _libraries([_interpreter(), *dynload]):
        mounts.setdefault(lib, os.path.realpath(lib))
    return mounts


def _hidden() -> list[str]:
    """Folders inside the mounted standard library that expansion must not see: its site-packages."""
    paths = _base_paths()
    return sorted({p for p in (paths["purelib"], paths["platlib"]) if os.path.isdir(p)})


def _libraries(files: Iterable[str]) -> list[str]:
    """The shared libraries `files` link to, as the dynamic loader resolves them (ldd), the loader included."""
    ldd = shutil.which("ldd")
    if ldd is None:
        raise Unavailable("ldd (Debian: libc-bin) is needed to find the libraries Python links to")
    done = subprocess.run([ldd, *files], capture_output=True, text=True,
                          env={"LC_ALL": "C", "PATH": "/usr/bin:/bin"})
    return sorted(set(re.findall(r"^\s+(?:\S+ => )?(/\S+) \(0x", done.stdout, re.M)))


def _packages(names: Iterable[str]) -> dict[str, str]:
    """Mounts of the installed packages (or modules) `names` at SITE/NAME."""
    mounts = {}
    for name in names:
        spec = find_spec(name)
        if spec is None or not (spec.submodule_search_locations or spec.origin):
            raise Unavailable(f"the Python package {name!r} is not installed")
        source = spec.submodule_search_locations[0] if spec.submodule_search_locations else str(spec.origin)
        mounts[f"{SITE}/{os.path.basename(source)}"] = os.path.realpath(source)
    return mounts


@functools.lru_cache(maxsize=1)
def _userns_refusal() -> str | None:
    """None if bwrap may create a user namespace here; else bwrap's reason."""
    done = subprocess.run([_bwrap(), "--unshare-user", "--ro-bind", "/", "/", "true"], capture_output=True, text=True)
    return None if done.returncode == 0 else (done.stderr.strip() or f"exit status {done.returncode}")


def _user() -> tuple[list[str], list[str]]:
    """bwrap arguments and a command prefix for the sandbox's user: uid NOBODY in a user namespace; where
    the kernel refuses one to a root server, the host's unprivileged user through setpriv."""
    refusal = _userns_refusal()
    if refusal is None:
        return ["--unshare-user", "--uid", str(NOBODY), "--gid", str(NOBODY)], []
    if os.geteuid() != 0:
        raise Unavailable(f"the kernel refuses a user namespace ({refusal})")
    setpriv = shutil.which("setpriv")
    if setpriv is None:
        raise Unavailable(f"the kernel refuses a user namespace ({refusal}), and setpriv (util-linux) is missing")
    try:
        uid, gid = pwd.getpwnam("nobody")[2:4]
    except KeyError:
        uid = gid = NOBODY
    return (["--cap-add", "CAP_SETUID", "--cap-add", "CAP_SETGID"],  # for setpriv, which then drops all
            [os.path.realpath(setpriv), f"--reuid={uid}", f"--regid={gid}", "--clear-groups", "--inh-caps=-all",
             "--bounding-set=-all", "--no-new-privs", "--"])


def run(program: Path, args: Iterable[str], read_only: Mapping[str, Path], stdin: bytes, timeout: float,
        max_output: int, packages: Iterable[str] = ()) -> tuple[int, bytes, bytes]:
    """Run `python program args` confined, each of `read_only`'s folders (sandbox path → host folder)
    visible read-only at its sandbox path, and the installed `packages` (import names) importable:
    (exit status, stdout, stderr), cut as bounded_run cuts them (the rest is read and dropped, so a
    flood costs no memory); TimeoutExpired past `timeout` seconds once started (waiting
    for one of the SLOTS is not counted), Unavailable where the machine cannot confine it."""
    bwrap, (user, prefix) = _bwrap(), _user()
    bpf = _seccomp_filter(SETPRIV_CALLS if prefix else ())
    read_fd, write_fd = os.pipe()  # bwrap reads the seccomp program from a file descriptor
    try:
        os.write(write_fd, bpf)  # a BPF program is a few hundred bytes: far below the pipe's buffer
    finally:
        os.close(write_fd)
    try:
        argv = _argv(bwrap, [*user, "--seccomp", str(read_fd)], prefix, program, args, read_only, packages)
        with SLOTS:
            return bounded_run(argv, stdin, timeout, max_output, pass_fds=(read_fd,))
    finally:
        os.close(read_fd)


def _argv(bwrap: str, options: list[str], prefix: list[str], program: Path, args: Iterable[str],
          read_only: Mapping[str, Path], packages: Iterable[str]) -> list[str]:
    """The command line: bwrap with its namespaces, `options` and the root it builds; `prefix`; python."""
    inside = f"{PROGRAM_DIR}/{program.name}"
    mounts = {**_runtime(), **_packages(packages), inside: str(program),
              **{target: str(source) for target, source in read_only.items()}}
    if prefix:
        mounts.update({lib: os.path.realpath(lib) for lib in [prefix[0], *_libraries(prefix[:1])]})
    argv = [bwrap, "--unshare-pid", "--unshare-net", "--unshare-ipc", "--unshare-uts", "--unshare-cgroup-try",
            "--hostname", HOSTNAME, "--die-with-parent", "--new-session", "--clearenv", "--cap-drop", "ALL", *options]
    argv += _mount_args(mounts) + ["--remount-ro", "/", "--chdir", "/"]
    return argv + prefix + [_interpreter(), "-I", "-S", "-B", "-c", BOOT, inside, *args]


def _mount_args(mounts: Mapping[str, str]) -> list[str]:
    """bwrap arguments building the root: every mount's ancestors world-traversable (bwrap would copy
    the host's modes), the mounts read-only (the standard library's site-packages hidden), /dev."""
    dests = sorted(mounts, key=lambda d: (d.count("/"), d))
    folders = [d for d in dests if os.path.isdir(mounts[d])]
    covered = {d for d in dests if any(d.startswith(f + "/") for f in folders)}  # seen through a folder already
    dests = [d for d in dests if d not in covered]
    ancestors = sorted({str(p) for d in dests for p in Path(d).parents if str(p) != "/"}, key=lambda d: d.count("/"))
    out = []
    for folder in ancestors + ["/dev"]:
        out += ["--perms", "0755", "--dir", folder]
    for dest in dests:
        out += ["--ro-bind", mounts[dest], dest]
    for folder in _hidden():
        if any(folder.startswith(f + "/") for f in dests):
            out += ["--tmpfs", folder, "--remount-ro", folder]
    for device in DEVICES:
        out += ["--dev-bind", device, device]
    return out


def bounded_run(argv: list[str], stdin: bytes, timeout: float, max_output: int, **popen: Any) -> tuple[int, bytes, bytes]:
    """subprocess.run keeping the first `max_output` bytes of stdout (read into one buffer) and the last
    min(`max_output`, MAX_ERROR) bytes of stderr (where an error's message is), reading and dropping the
    rest; past `timeout` seconds the child's process group (the child starts one) is killed and
    TimeoutExpired raised."""
    with subprocess.Popen(argv, stdin=subprocess.PIPE, stdout=subprocess.PIPE, stderr=subprocess.PIPE,
                          start_new_session=True, **popen) as proc:
        if proc.stdin is None:
            raise RuntimeError("the child has no stdin pipe")
        outputs: dict[str, bytes] = {}

        def head(stream) -> None:
            outputs["out"] = stream.read(max_output)
            while stream.read(65536):
                pass

        def tail(stream, limit: int = min(max_output, MAX_ERROR)) -> None:
            kept = b""
            while chunk := stream.read(65536):
                kept = (kept + chunk)[-limit:]
            outputs["err"] = kept

        readers = [threading.Thread(target=read, args=(stream,), daemon=True)
                   for read, stream in ((head, proc.stdout), (tail, proc.stderr))]
        for t in readers:
            t.start()
        try:
            try:
                proc.stdin.write(stdin)
                proc.stdin.close()
            except BrokenPipeError:
                pass
            proc.wait(timeout)
        except subprocess.TimeoutExpired:
            _kill_group(proc)
            raise
        finally:
            for t in readers:
                t.join(5)
        return proc.returncode, outputs.get("out", b""), outputs.get("err", b"")


def _kill_group(proc: subprocess.Popen) -> None:
    """SIGKILL the process group `proc` leads (a sandbox's PID namespace dies with bwrap), then reap it."""
    try:
        os.killpg(proc.pid, signal.SIGKILL)
    except ProcessLookupError:
        pass
    proc.wait()


@functools.lru_cache(maxsize=1)
def unavailable() -> str | None:
    """None if a confined program runs here; else why not (checked once per process)."""
    try:
        code, out, err = run(Path(__file__).with_name("sandbox_probe.py"), [], {}, b"", 20, 4096)
    except Unavailable as e:
        return str(e)
    except (OSError, subprocess.TimeoutExpired) as e:
        return f"the sandbox could not be started ({e})"
    if code != 0 or out.strip() != b"confined":
        reason = err.decode("utf-8", "replace").strip().splitlines()[-1:] or [f"exit status {code}"]
        return f"the sandbox could not be started ({reason[0]})"
    return None
