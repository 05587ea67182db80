"""Run by pipeline.reading.sandbox.unavailable() inside the sandbox: prints "confined" only if the boundary holds
(no root, no sockets, no new processes, no host files)."""
import os
import socket
import sys


def main() -> int:
    failures = []
    if os.getuid() == 0 or os.geteuid() == 0:
        failures.append("runs as root")
    try:
        socket.socket(socket.AF_INET, socket.SOCK_STREAM).close()
        failures.append("may open sockets")
    except OSError:
        pass
    try:
        pid = os.fork()
        if pid == 0:
            os._exit(0)
        os.waitpid(pid, 0)
        failures.append("may start processes")
    except OSError:
        pass
    if os.path.exists("/etc/passwd") or os.path.exists("/proc/1"):
        failures.append("sees host files")
    print("confined" if not failures else "not confined: " + ", ".join(failures))
    return 0


if __name__ == "__main__":
    sys.exit(main())
