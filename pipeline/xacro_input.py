"""xacro robot descriptions: expanded to URDF by the ROS `xacro` package in a bounded child process.

The child (`pipeline/xacro_worker.py`, started as `python -I FILE` without a shell) has CPU,
memory and time limits and may read only the main file's folder (command line) and the package
paths given; see its docstring for every guard. Every refusal is a XacroError (a URDFError)
naming the file and line.
"""
from __future__ import annotations

import json
import os
import subprocess
import sys
import tempfile
import threading
from collections.abc import Iterable, Mapping
from pathlib import Path

from urdfkb.pipeline.errors import URDFError
from urdfkb.pipeline.ingest import DEFAULT_MAX_BYTES, DEFAULT_MAX_LINKS, load_urdf
from urdfkb.pipeline.tree import KinematicTree

WORKER = Path(__file__).with_name("xacro_worker.py")
TIMEOUT = 20.0          # seconds of wall time for one expansion
CPU_SECONDS = 10
MEMORY = 1 << 30        # address space of the child
XACRO_NS = b"http://www.ros.org/wiki/xacro"
_RUNNING = threading.BoundedSemaphore(2)  # at most two children (2 x MEMORY) at once per process


class XacroError(URDFError):
    """A xacro document that cannot be expanded: the message names file and line."""


def is_xacro(filename: str | None, data: bytes) -> bool:
    """A `.xacro` file name, or a document declaring the xacro namespace."""
    return bool(filename and filename.endswith(".xacro")) or XACRO_NS in data[:4096]


def parse_args(items: Iterable[str]) -> dict[str, str]:
    """`name:=value` strings (as on the xacro command line) as a mapping; XacroError otherwise."""
    out = {}
    for item in items:
        name, sep, value = item.partition(":=")
        if not sep or not name.strip() or not name.strip().replace("_", "a").isalnum():
            raise XacroError(f"xacro argument {item!r} is not NAME:=VALUE")
        out[name.strip()] = value
    return out


def parse_package_paths(items: Iterable[str]) -> dict[str, Path]:
    """`NAME=DIR` strings as a mapping to existing directories; XacroError otherwise."""
    out = {}
    for item in items:
        name, sep, folder = item.partition("=")
        if not sep or not name or "/" in name:
            raise XacroError(f"package path {item!r} is not NAME=DIR")
        path = Path(folder).expanduser()
        if not path.is_dir():
            raise XacroError(f"package path {name}={folder}: no such directory")
        out[name] = path.resolve()
    return out


def expand(data: bytes, name: str, *, main_dir: str | os.PathLike | None = None,
           args: Mapping[str, str] | None = None, packages: Mapping[str, Path] | None = None,
           max_bytes: int = DEFAULT_MAX_BYTES, timeout: float = TIMEOUT) -> bytes:
    """The URDF that xacro document `data` (called `name`) expands to.

    Includes, `$(find NAME)` and `package://NAME/` resolve inside `main_dir` (None for uploads:
    then nothing beside the package paths) and `packages` only; `args` are the xacro:arg values.
    """
    if len(data) > max_bytes:
        raise XacroError(f"{name}: too large: over the {max_bytes}-byte limit")
    request = {"text": data.decode("utf-8", "replace"), "name": name,
               "main_dir": str(Path(main_dir).resolve()) if main_dir else None,
               "args": dict(args or {}), "packages": {k: str(v) for k, v in (packages or {}).items()},
               "max_bytes": max_bytes}
    limits = json.dumps({"memory": MEMORY, "cpu": CPU_SECONDS})
    with _RUNNING, tempfile.TemporaryDirectory(prefix="urdfkb-xacro-") as empty:
        try:
            proc = subprocess.run([sys.executable, "-I", str(WORKER), limits], input=json.dumps(request).encode(),
                                  capture_output=True, timeout=timeout, cwd=empty, env={"PATH": "/usr/bin:/bin"})
        except subprocess.TimeoutExpired:
            raise XacroError(f"{name}: expansion took longer than {timeout:.0f} s (a macro or expression that does not end?)") from None
    if proc.returncode != 0 or not proc.stdout:
        raise XacroError(f"{name}: expansion stopped by its CPU or memory limit (an expression or macro that grows "
                         f"without bound?){_tail(proc.stderr)}")
    answer = json.loads(proc.stdout)
    if "error" in answer:
        raise XacroError(answer["error"])
    return answer["urdf"].encode()


def _tail(stderr: bytes) -> str:
    lines = stderr.decode("utf-8", "replace").strip().splitlines()
    return f": {lines[-1]}" if lines and "Error" in lines[-1] else ""


def load_description(source: str | os.PathLike | bytes, *, filename: str | None = None,
                     args: Mapping[str, str] | None = None, packages: Mapping[str, Path] | None = None,
                     max_bytes: int = DEFAULT_MAX_BYTES, max_links: int = DEFAULT_MAX_LINKS,
                     trust_folder: bool = True) -> KinematicTree:
    """A URDF or xacro file (path) or document (bytes) as a checked tree.

    For a path, the file's own folder may be read by includes when `trust_folder` (the command
    line); uploaded bytes never read anything but the package paths."""
    main_dir = None
    if isinstance(source, bytes):
        data = source
    else:
        path = Path(source)
        try:
            size = path.stat().st_size
        except OSError as e:
            raise URDFError(f"cannot read {path}: {e.strerror}") from None
        if size > max_bytes:
            raise URDFError(f"{path}: too large: over the {max_bytes}-byte limit ({size} bytes)")
        data, filename = path.read_bytes(), filename or path.name
        main_dir = path.parent if trust_folder else None
    if not is_xacro(filename, data):
        if args:
            raise XacroError(f"xacro arguments given, but {filename or 'the document'} is not a xacro file")
        return load_urdf(data, max_bytes=max_bytes, max_links=max_links)
    urdf = expand(data, filename or "robot.urdf.xacro", main_dir=main_dir, args=args, packages=packages,
                  max_bytes=max_bytes)
    try:
        return load_urdf(urdf, max_bytes=max_bytes, max_links=max_links)
    except URDFError as e:
        raise URDFError(f"{filename}: expands to an invalid URDF: {e}") from None
