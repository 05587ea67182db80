"""An operating-system boundary for running untrusted code: bubblewrap with a seccomp filter.

Used for xacro documents sent to the server (xacro's `${...}` is Python, so an upload is code).
`run()` runs its program:

- in new PID, network, IPC and UTS namespaces (`bwrap --unshare-*`): it sees no other process, so
  it can signal, trace or `pidfd_open` none, and has no network but an unconfigured loopback;
- on a fresh read-only root holding only the system's runtime (`/usr` and its `/lib*` links), the
  Python installation, the program itself and the folders the caller names, all read-only: no
  `/home`, `/root`, `/etc`, `/tmp`, `/proc` or working tree of the host;
- with every capability dropped and, where the server runs as root, as the unprivileged user
  `nobody` (`setpriv`), with no way back (`no_new_privs`);
- behind a seccomp filter (libseccomp through pyseccomp) refusing what an expansion never needs:
  new processes or threads, sockets, ptrace and process-memory access, pidfd signalling, mounts
  and namespaces, keyrings, BPF, io_uring, module loading;
- in its own session (no terminal injection), killed with its parent (`--die-with-parent`).

CPU, memory and file-size limits are rlimits the program sets before reading any input, and the
caller reads its output with a cap and a wall-clock timeout. `unavailable()` says why a machine
cannot provide this (no bwrap, no libseccomp, namespaces refused), so callers can refuse instead.
"""
from __future__ import annotations

import errno
import functools
import os
import pwd
import shutil
import signal
import subprocess
import sys
import tempfile
import threading
from collections.abc import Iterable, Mapping
from pathlib import Path

UNPRIVILEGED_USER = "nobody"
# Syscalls an expansion never makes: refused with EPERM (ENOSYS for clone3, so libc falls back to clone).
DENIED = ("ptrace", "process_vm_readv", "process_vm_writev", "pidfd_open", "pidfd_send_signal", "pidfd_getfd",
          "fork", "vfork", "clone", "socket", "socketpair", "bpf", "perf_event_open", "userfaultfd",
          "keyctl", "add_key", "request_key", "mount", "umount2", "pivot_root", "chroot", "unshare", "setns",
          "io_uring_setup", "io_uring_enter", "io_uring_register", "init_module", "finit_module",
          "delete_module", "kexec_load", "kexec_file_load", "reboot", "swapon", "swapoff", "acct",
          "open_by_handle_at", "name_to_handle_at", "fanotify_init", "move_mount", "open_tree", "fsopen",
          "fsmount", "fspick", "mount_setattr")
PROGRAM_DIR = "/urdfkb"  # where the program is mounted inside


class Unavailable(RuntimeError):
    """This machine cannot confine a program (the message says what is missing)."""


def _bwrap() -> str:
    path = shutil.which("bwrap")
    if path is None:
        raise Unavailable("bubblewrap (bwrap) is not installed (Debian: apt-get install bubblewrap)")
    return path


def _seccomp_filter() -> bytes:
    """The compiled BPF program of the DENIED list (raises Unavailable without libseccomp)."""
    try:
        import pyseccomp as seccomp
    except (ImportError, OSError, TypeError) as e:  # pyseccomp raises on import when libseccomp is missing
        raise Unavailable(f"libseccomp is not usable through pyseccomp ({e})") from None
    rules = seccomp.SyscallFilter(defaction=seccomp.ALLOW)
    for name in DENIED:
        try:
            rules.add_rule(seccomp.ERRNO(errno.EPERM), name)
        except (OSError, ValueError, RuntimeError):  # a syscall this architecture does not have
            pass
    rules.add_rule(seccomp.ERRNO(errno.ENOSYS), "clone3")
    with tempfile.TemporaryFile() as f:
        rules.export_bpf(f)
        f.seek(0)
        return f.read()


def _runtime_binds() -> list[str]:
    """bwrap arguments mounting the system runtime and the Python installation read-only."""
    args = ["--ro-bind", "/usr", "/usr"]
    for top in ("/bin", "/sbin", "/lib", "/lib32", "/lib64", "/libx32"):
        if os.path.islink(top):
            args += ["--symlink", os.readlink(top), top]
        elif os.path.isdir(top):
            args += ["--ro-bind", top, top]
    pythons = {os.path.realpath(p) for p in (sys.base_prefix, sys.prefix, os.path.dirname(os.path.realpath(sys.executable)))}
    for path in sorted(pythons):
        if not path.startswith("/usr/") and path != "/usr":
            args += _dirs_to(path) + ["--ro-bind", path, path]
    return args


def _dirs_to(path: str) -> list[str]:
    """bwrap arguments creating `path`'s ancestors world-traversable (bwrap copies the host's modes)."""
    out, parts = [], Path(path).parts[1:-1]
    for i in range(len(parts)):
        out += ["--perms", "0755", "--dir", "/" + "/".join(parts[: i + 1])]
    return out


def _drop_user() -> list[str]:
    """A command prefix making a root sandbox run as the unprivileged user (nothing if not root)."""
    if os.geteuid() != 0:
        return []
    try:
        entry = pwd.getpwnam(UNPRIVILEGED_USER)
        uid, gid = entry.pw_uid, entry.pw_gid
    except KeyError:
        uid = gid = 65534
    setpriv = shutil.which("setpriv")
    if setpriv is None:
        raise Unavailable("setpriv (util-linux) is needed to leave root inside the sandbox")
    return [setpriv, f"--reuid={uid}", f"--regid={gid}", "--clear-groups", "--inh-caps=-all",
            "--bounding-set=-all", "--no-new-privs", "--"]


def run(program: Path, args: Iterable[str], read_only: Mapping[str, Path], stdin: bytes, timeout: float,
        max_output: int) -> tuple[int, bytes, bytes]:
    """Run `python -I program args` confined, each of `read_only`'s folders (sandbox path → host folder)
    visible read-only at its sandbox path: (exit status, stdout, stderr), each output cut at
    `max_output` bytes (the rest is read and dropped, so a flood costs no memory); TimeoutExpired past
    `timeout`, Unavailable where the machine cannot confine it."""
    bwrap, bpf = _bwrap(), _seccomp_filter()
    read_fd, write_fd = os.pipe()  # bwrap reads the seccomp program from a file descriptor
    try:
        os.write(write_fd, bpf)  # a BPF program is a few hundred bytes: far below the pipe's buffer
    finally:
        os.close(write_fd)
    try:
        return bounded_run(_argv(bwrap, read_fd, program, args, read_only), stdin, timeout, max_output,
                           pass_fds=(read_fd,))
    finally:
        os.close(read_fd)


def _argv(bwrap: str, seccomp_fd: int, program: Path, args: Iterable[str], read_only: Mapping[str, Path]) -> list[str]:
    inside = f"{PROGRAM_DIR}/{program.name}"
    argv = [bwrap, "--unshare-pid", "--unshare-net", "--unshare-ipc", "--unshare-uts", "--unshare-cgroup-try",
            "--die-with-parent", "--new-session", "--clearenv", "--setenv", "PATH", "/usr/bin:/bin",
            "--cap-drop", "ALL"]
    if os.geteuid() == 0:
        argv += ["--cap-add", "CAP_SETUID", "--cap-add", "CAP_SETGID"]  # for setpriv, which then drops all
    else:
        argv += ["--unshare-user"]
    argv += _runtime_binds() + ["--dev", "/dev"]
    argv += _dirs_to(inside) + ["--ro-bind", str(program), inside]
    for target, source in read_only.items():
        argv += _dirs_to(target) + ["--ro-bind", str(source), target]
    argv += ["--remount-ro", "/", "--chdir", "/", "--seccomp", str(seccomp_fd)]
    return argv + _drop_user() + [sys.executable, "-I", inside, *args]


def bounded_run(argv: list[str], stdin: bytes, timeout: float, max_output: int, **popen) -> tuple[int, bytes, bytes]:
    """subprocess.run with outputs capped at `max_output` bytes each; past `timeout` seconds the child's
    process group (the child starts one) is killed and TimeoutExpired raised."""
    with subprocess.Popen(argv, stdin=subprocess.PIPE, stdout=subprocess.PIPE, stderr=subprocess.PIPE,
                          start_new_session=True, **popen) as proc:
        if proc.stdin is None:
            raise RuntimeError("the child has no stdin pipe")
        outputs: dict[str, bytes] = {}

        def drain(name: str, stream) -> None:
            kept, size = [], 0
            while chunk := stream.read(65536):
                if size < max_output:
                    kept.append(chunk[: max_output - size])
                size += len(chunk)
            outputs[name] = b"".join(kept)

        readers = [threading.Thread(target=drain, args=(n, s), daemon=True)
                   for n, s in (("out", proc.stdout), ("err", proc.stderr))]
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
