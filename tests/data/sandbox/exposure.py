"""What a program confined by pipeline.reading.sandbox sees of the host; run by tests/test_xacro_sandbox.py.

argv: the server's venv, the standard library's site-packages, then NAME=NUMBER system calls to make
through ctypes. Prints a JSON object: each fact, or the error that kept it hidden."""
import ctypes
import json
import os
import socket
import sys


def attempt(action):
    try:
        return action()
    except OSError as e:
        return f"refused: errno {e.errno}"
    except Exception as e:
        return f"refused: {type(e).__name__}"


libc = ctypes.CDLL(None, use_errno=True)
SYSCALL_ARGS = {"personality": (0xFFFFFFFF,), "uname": (None,), "socket": (2, 1, 0), "unshare": (0,), "sethostname": (None, 0)}


def syscall(name, number):
    if libc.syscall(number, *SYSCALL_ARGS[name]) == -1:
        raise OSError(ctypes.get_errno(), name)
    return "allowed"


venv, site_packages = sys.argv[1:3]
facts = {
    "uid": os.getuid(),
    "host name": attempt(socket.gethostname),
    "uname": attempt(lambda: list(os.uname())),
    "/dev": sorted(os.listdir("/dev")),
    "/dev/pts": attempt(lambda: open("/dev/pts/ptmx", "rb").close()),
    "/dev/tty": attempt(lambda: open("/dev/tty", "rb").close()),
    "the root": sorted(os.listdir("/")),
    "/usr/local": os.path.exists("/usr/local"),
    "/bin/sh": os.path.exists("/bin/sh"),
    "the venv": os.path.exists(venv),
    "site-packages": attempt(lambda: os.listdir(site_packages)),
    "import pip": attempt(lambda: __import__("pip") and "imported"),
}
for arg in sys.argv[3:]:
    name, number = arg.split("=")
    facts[f"syscall {name}"] = attempt(lambda: syscall(name, int(number)))
print(json.dumps(facts))
