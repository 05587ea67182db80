"""What code that escaped xacro's guards would try next; run inside pipeline.reading.sandbox by
tests/test_xacro_sandbox.py. Prints a JSON list of the attacks that succeeded (none, if confined).

argv: the host pid to signal, a host file to read, the package file (sandbox path) to change."""
import json
import os
import socket
import subprocess
import sys

target_pid, host_file, package_file = int(sys.argv[1]), sys.argv[2], sys.argv[3]


def attempt(name, action):
    try:
        action()
    except Exception:  # refused: the boundary held
        return None
    return name


def fork():
    pid = os.fork()
    if pid == 0:
        os._exit(0)
    os.waitpid(pid, 0)


succeeded = [
    attempt("run a command", lambda: subprocess.run(["id", "-u"], check=True, capture_output=True)),
    attempt("start a process", fork),
    attempt("open a socket", lambda: socket.socket(socket.AF_INET, socket.SOCK_STREAM).close()),
    attempt("open a unix socket", lambda: socket.socket(socket.AF_UNIX).close()),
    attempt("signal the server", lambda: os.kill(target_pid, 0)),
    attempt("pidfd_open the server", lambda: os.close(os.pidfd_open(target_pid))),
    attempt("read a host file", lambda: open(host_file, "rb").read()),
    attempt("read /etc/passwd", lambda: open("/etc/passwd", "rb").read()),
    attempt("list /proc", lambda: os.listdir("/proc/1")),
    attempt("truncate a package file", lambda: os.close(os.open(package_file, os.O_WRONLY | os.O_TRUNC))),
    attempt("write a file", lambda: open("/planted", "w").write("x")),
    attempt("run as root", lambda: None if os.geteuid() == 0 else 1 / 0),
]
print(json.dumps([s for s in succeeded if s]))
