"""xacro robot descriptions: expanded to URDF by the ROS `xacro` package in a bounded child process.

xacro's `${...}` expressions are Python, so a xacro document is code. The child
(`pipeline/reading/xacro_worker.py`, started as `python -I FILE` without a shell) sets CPU, memory and
file-size limits and lowers its priority before reading its input, and may read only the main
file's folder (command line) and the package paths given; see its docstring for every guard.
Those guards live in the interpreter that runs the expression, so for documents from strangers
(`confined=True`, the server) the child also runs inside the operating-system boundary of
pipeline.reading.sandbox (bubblewrap and seccomp, as an unprivileged user). Its output is read with a cap, it
is killed past its wall-clock limit, and at most one expansion runs per core at once (sandbox.SLOTS).
Every refusal is a XacroError (a URDFError) naming the file and line.
"""
from __future__ import annotations

import json
import os
import subprocess
import sys
import tempfile
from collections.abc import Iterable, Mapping
from pathlib import Path
from xml.parsers import expat

from urdfkb.pipeline.reading import sandbox
from urdfkb.pipeline.errors import URDFError
from urdfkb.pipeline.reading.ingest import load_urdf
from urdfkb.pipeline.reading.tree import KinematicTree
from urdfkb.settings import MAX_BYTES, MAX_ERROR, MAX_LINKS, XACRO_CPU_SECONDS, XACRO_MEMORY, XACRO_TIMEOUT

WORKER = Path(__file__).with_name("xacro_worker.py")
SANDBOX_PACKAGES = "/packages"  # where package paths are mounted inside the sandbox
SANDBOX_MAIN = "/main"
XACRO_NS = b"http://www.ros.org/wiki/xacro"
PACKAGES = ("xacro", "yaml", "defusedxml")  # what the worker imports besides the standard library


class XacroError(URDFError):
    """A xacro document that cannot be expanded: the message names file and line."""

    status = 400


def is_xacro(filename: str | None, data: bytes) -> bool:
    """A `.xacro` file name, or a document that uses xacro (see uses_xacro)."""
    return bool(filename and filename.endswith(".xacro")) or uses_xacro(data)


class _Used(Exception):
    """Raised by uses_xacro's handlers at the first use of xacro, ending the parse."""


def uses_xacro(data: bytes) -> bool:
    """Whether a document uses xacro: an element or attribute named `xacro:...` (what xacro expands), or,
    in a document declaring the xacro namespace, a `${...}` or `$(...)` substitution in an attribute
    value or text. Comments do not count.

    The declaration alone is no use: xacro writes it into the URDFs it expands. Without it, `${` is
    read as text: published URDFs carry such half-expanded left-overs, which xacro could not evaluate
    either. A document with a DTD, or not XML before its first use of xacro, is no xacro here: the
    URDF reader refuses it, naming why. A byte search settles most documents; the others get one expat pass, with no tree and
    ended at the first use (linear: 1.5 s of CPU for 10 MB of one-line elements)."""
    declared = XACRO_NS in data or b"xmlns:xacro" in data
    if b"xacro:" not in data and not (declared and (b"${" in data or b"$(" in data)):
        return False
    parser = expat.ParserCreate()
    last = ""  # the previous piece of the current text (expat may deliver a text in pieces)

    def start(tag: str, attrs: dict[str, str]) -> None:
        nonlocal last
        last = ""
        if tag.startswith("xacro:"):
            raise _Used
        for name, value in attrs.items():
            if name.startswith("xacro:") or declared and ("${" in value or "$(" in value):
                raise _Used

    def end(tag: str) -> None:
        nonlocal last
        last = ""

    def character_data(piece: str) -> None:
        nonlocal last
        if declared and ("${" in piece or "$(" in piece or last.endswith("$") and piece.startswith(("{", "("))):
            raise _Used
        last = piece

    def doctype(*_) -> None:
        raise expat.ExpatError("a DTD")

    parser.StartElementHandler, parser.EndElementHandler = start, end
    parser.CharacterDataHandler, parser.StartDoctypeDeclHandler = character_data, doctype
    try:
        parser.Parse(data, True)
    except _Used:
        return True
    except expat.ExpatError:
        pass
    return False


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
           max_bytes: int = MAX_BYTES, timeout: float = XACRO_TIMEOUT, confined: bool = False) -> bytes:
    """The URDF that xacro document `data` (called `name`) expands to.

    Includes, `$(find NAME)` and `package://NAME/` resolve inside `main_dir` (None for uploads:
    then nothing beside the package paths) and `packages` only; `args` are the xacro:arg values.
    `confined` runs the child inside pipeline.reading.sandbox (sandbox.Unavailable where it cannot). Past
    `timeout` seconds of wall time the child and everything it started are killed."""
    if len(data) > max_bytes:
        raise XacroError(f"{name}: too large: over the {max_bytes}-byte limit")
    packages = {k: Path(v).resolve() for k, v in (packages or {}).items()}
    main = Path(main_dir).resolve() if main_dir else None
    if confined:  # the child sees these folders at fixed places, and never the host's paths
        mounts = {f"{SANDBOX_PACKAGES}/{k}": v for k, v in packages.items()} | ({SANDBOX_MAIN: main} if main else {})
        seen_packages = {k: f"{SANDBOX_PACKAGES}/{k}" for k in packages}
        seen_main = SANDBOX_MAIN if main else None
    else:
        seen_packages, seen_main = {k: str(v) for k, v in packages.items()}, str(main) if main else None
    request = {"text": data.decode("utf-8", "replace"), "name": name, "main_dir": seen_main,
               "args": dict(args or {}), "packages": seen_packages, "max_bytes": max_bytes,
               "max_error": MAX_ERROR // 2}  # cut in the child; half, so what callers put before it is kept too
    limits = json.dumps({"memory": XACRO_MEMORY, "cpu": XACRO_CPU_SECONDS})
    cap = 2 * max_bytes + 65536  # the JSON answer around an expanded URDF of at most max_bytes
    try:
        if confined:
            code, out, err = sandbox.run(WORKER, [limits], mounts, json.dumps(request).encode(), timeout, cap, PACKAGES)
        else:
            with sandbox.SLOTS, tempfile.TemporaryDirectory(prefix="urdfkb-xacro-") as empty:
                code, out, err = sandbox.bounded_run([sys.executable, "-I", str(WORKER), limits],
                                                     json.dumps(request).encode(), timeout, cap,
                                                     cwd=empty, env={"PATH": "/usr/bin:/bin"})
    except subprocess.TimeoutExpired:
        raise XacroError(f"{name}: expansion took longer than {timeout:g} s, the xacro time limit (wall time, "
                         "--xacro-timeout): a macro or expression that does not end, or waits?") from None
    except sandbox.Unavailable as e:
        raise XacroError(f"{name}: cannot confine the expansion: {e}") from None
    if code != 0 or not out:
        raise XacroError(f"{name}: expansion stopped by its CPU or memory limit (an expression or macro that grows "
                         f"without bound?){_tail(err)}")
    try:
        answer = json.loads(out)
    except ValueError:
        raise XacroError(f"{name}: expansion wrote more than {cap} bytes or no answer") from None
    if "error" in answer:
        raise XacroError(answer["error"])
    return answer["urdf"].encode()


def _tail(stderr: bytes) -> str:
    lines = stderr.decode("utf-8", "replace").strip().splitlines()
    return f": {lines[-1]}" if lines and "Error" in lines[-1] else ""


def refuse_args(filename: str | None, args: Mapping[str, str] | None) -> None:
    """XacroError where xacro arguments come with a document that is not a xacro file."""
    if args:
        raise XacroError(f"xacro arguments given, but {filename or 'the document'} is not a xacro file")


def load_description(source: str | os.PathLike | bytes, *, filename: str | None = None,
                     args: Mapping[str, str] | None = None, packages: Mapping[str, Path] | None = None,
                     max_bytes: int = MAX_BYTES, max_links: int = MAX_LINKS, timeout: float = XACRO_TIMEOUT,
                     trust_folder: bool = True, confined: bool = False) -> KinematicTree:
    """A URDF or xacro file (path) or document (bytes) as a checked tree.

    For a path, the file's own folder may be read by includes when `trust_folder` (the command
    line); uploaded bytes never read anything but the package paths. `timeout`, `confined`: see expand()."""
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
        refuse_args(filename, args)
        return load_urdf(data, max_bytes=max_bytes, max_links=max_links)
    urdf = expand(data, filename or "robot.urdf.xacro", main_dir=main_dir, args=args, packages=packages,
                  max_bytes=max_bytes, timeout=timeout, confined=confined)
    try:
        return load_urdf(urdf, max_bytes=max_bytes, max_links=max_links)
    except URDFError as e:
        raise URDFError(f"{filename}: expands to an invalid URDF: {e}") from None
