"""Expand one xacro document inside a bounded child process (run by pipeline.reading.xacro_input, never a shell).

Reads a JSON request on stdin, writes {"urdf": text} or {"error": message} on stdout, the message cut to
the request's `max_error` characters (xacro echoes what it could not evaluate: megabytes). The ROS
`xacro` package evaluates `${...}` with Python's eval and `$(eval ...)` with full builtins, so it
cannot be trusted with hostile input in the server's own process. The guards below run in the same
interpreter as the expressions, so they only help an honest document fail clearly; for documents
from strangers the real boundary is the operating system's (pipeline.reading.sandbox: bubblewrap, seccomp,
an unprivileged user), around this process. Here it runs with:

- CPU, address-space and file-size limits and the lowest CPU priority, set before any input is read;
- a Python audit hook (which nothing can remove) refusing processes, sockets, native code and
  every file write, and file reads outside the allowed directories;
- `open` in xacro's module replaced by one that resolves `package://NAME/` and only opens files
  inside the allowed directories (the main file's folder on the command line, and the package
  paths given), each file first checked by defusedxml (no DTD, no entities);
- `$(eval ...)` and `$(env ...)` refused, `$(optenv NAME default)` answering its default,
  `$(find NAME)` resolving only among the package paths given;
- include and macro nesting depth and total bytes read bounded; errors name file and line.

Only the standard library, defusedxml and xacro are imported (the worker starts with `python -I`).
"""
from __future__ import annotations

import json
import os
import resource
import sys
import weakref
import xml.dom.expatbuilder
import xml.dom.minidom
import xml.parsers.expat
from typing import IO, Any

import defusedxml.ElementTree as DET
import yaml  # noqa: F401  (xacro imports it lazily; loaded before the audit hook)
from defusedxml.common import DefusedXmlException

import xacro
from xacro import substitution_args

MAX_INCLUDE_DEPTH = 20
MAX_MACRO_DEPTH = 50
MAX_FILES = 500
# (file, line) of each element parsed, and of each failure an element's place is known for
WHERE: weakref.WeakKeyDictionary[object, tuple[str, object]] = weakref.WeakKeyDictionary()


class Disallowed(Exception):
    """Something the request may not do; the message says what (and `where`, if given, where). Raised and
    answered in this child only: its message reaches the server as the XacroError of pipeline.reading.xacro_input
    (the worker imports nothing of urdfkb, so this is not a UrdfkbError)."""

    def __init__(self, message: str, where: tuple[str, object] | None = None):
        super().__init__(message)
        if where:
            WHERE[self] = where


class Request:
    def __init__(self, data: dict):
        self.text: str = data["text"]
        self.name: str = data["name"]
        self.main_dir: str | None = data.get("main_dir")
        self.args: dict[str, str] = data.get("args", {})
        self.packages = {k: os.path.realpath(v) for k, v in data.get("packages", {}).items()}
        self.max_bytes: int = data["max_bytes"]
        self.max_error: int = data["max_error"]
        roots = list(self.packages.values()) + ([os.path.realpath(self.main_dir)] if self.main_dir else [])
        self.roots = [r.rstrip(os.sep) + os.sep for r in roots]
        self.bytes_read = len(self.text.encode())
        self.files = 0

    def inside(self, path: str) -> bool:
        real = os.path.realpath(path)
        return any(real.startswith(r) for r in self.roots)

    def resolve(self, path: str) -> str:
        """A filesystem path for an include spec (package:// mapped); Disallowed outside the roots."""
        if "package://" in path:
            rest = path.split("package://", 1)[1]
            pkg, _, rel = rest.partition("/")
            if pkg not in self.packages:
                raise Disallowed(f"unknown package {pkg!r} in 'package://{rest}' ({self._known()})")
            path = os.path.join(self.packages[pkg], rel)
        if not self.inside(path):
            raise Disallowed(f"include {self.display(path)!r} is outside the allowed directories ({self._known()})")
        return os.path.realpath(path)

    def display(self, path: str | None) -> str:
        """How a file is named in messages: package://NAME/rel for package files, never another server path."""
        if path is None:
            return self.name
        real = os.path.realpath(path)
        for pkg, root in self.packages.items():
            if real.startswith(root.rstrip(os.sep) + os.sep):
                return f"package://{pkg}/{os.path.relpath(real, root)}"
        if self.main_dir and real.startswith(os.path.realpath(self.main_dir) + os.sep):
            return path
        return os.path.basename(path)

    def _known(self) -> str:
        if not self.packages:
            return "no package paths are configured"
        return "package paths: " + ", ".join(sorted(self.packages))


REQ: Request


class _LocatingBuilder(xml.dom.expatbuilder.ExpatBuilderNS):
    """minidom's namespace-aware builder, recording (file, line) on every element."""

    where = "?"

    def start_element_handler(self, name, attributes):
        super().start_element_handler(name, attributes)
        WHERE[self.curNode] = (self.where, self.getParser().CurrentLineNumber)


def parse_text(text: str, display: str) -> xml.dom.minidom.Document:
    """A DOM of `text` after defusedxml's checks; element locations recorded."""
    try:
        DET.fromstring(text.encode())
    except DefusedXmlException as e:
        raise Disallowed(f"DTDs and entities are not allowed in xacro ({type(e).__name__})", (display, 1)) from None
    except DET.ParseError as e:
        line = e.position[0] if getattr(e, "position", None) else "?"
        raise Disallowed(f"not well-formed XML: {e}", (display, line)) from None
    builder = _LocatingBuilder()
    builder.where = display
    return builder.parseString(text)


def guarded_parse(inp: object, filename: str | None = None) -> xml.dom.minidom.Document:
    """Replaces xacro.parse: includes open through REQ.resolve, with size and count limits."""
    if inp is not None:
        return xacro.parse.__wrapped__(inp, filename)
    if filename is None:
        raise Disallowed("xacro asked to parse neither a text nor a file")
    try:
        path = REQ.resolve(filename)
    except Disallowed:
        xacro.filestack.pop()  # the include is not being processed: name the including file
        raise
    REQ.files += 1
    if REQ.files > MAX_FILES:
        raise Disallowed(f"more than {MAX_FILES} files included")
    try:
        with open(path, "rb") as f:
            data = f.read(REQ.max_bytes + 1)
    except OSError as e:
        xacro.filestack.pop()
        raise Disallowed(f"cannot read include {REQ.display(path)!r}: {e.strerror}") from None
    REQ.bytes_read += len(data)
    if REQ.bytes_read > REQ.max_bytes:
        raise Disallowed(f"the xacro files read exceed the {REQ.max_bytes} byte limit")
    return parse_text(data.decode("utf-8", "replace"), REQ.display(path))


guarded_parse.__wrapped__ = xacro.parse  # type: ignore[attr-defined]


def guarded_open(file: str, *args: Any, **kwargs: Any) -> IO[Any]:
    """xacro's other file access (xacro.load_yaml): only inside the allowed directories."""
    return open(REQ.resolve(file), *args, **kwargs)


def _locate(func):
    """Wrap a xacro function whose first argument is an element: failures remember that element's place."""
    def wrapper(node, *args, **kwargs):
        try:
            return func(node, *args, **kwargs)
        except Exception as e:
            if e not in WHERE and node in WHERE:
                WHERE[e] = WHERE[node]
            raise
    return wrapper


def _bounded_include(func):
    def wrapper(elt, *args, **kwargs):
        if len(xacro.filestack) > MAX_INCLUDE_DEPTH:
            raise Disallowed(f"includes nested deeper than {MAX_INCLUDE_DEPTH} (an include loop?)")
        return func(elt, *args, **kwargs)
    return wrapper


def _bounded_macro(func):
    def wrapper(node, *args, **kwargs):
        if len(xacro.macrostack or []) > MAX_MACRO_DEPTH:
            raise Disallowed(f"macros nested deeper than {MAX_MACRO_DEPTH} (a macro that calls itself without end?)")
        return func(node, *args, **kwargs)
    return wrapper


def _no_eval(s, context):
    raise Disallowed("$(eval ...) is not supported (it runs arbitrary Python); use ${...} expressions")


def _no_env(name):
    raise Disallowed(f"$(env {name}) is not available: the server's environment is not exposed")


def _find(pkg):
    if pkg not in REQ.packages:
        raise Disallowed(f"$(find {pkg}): unknown package ({REQ._known()})")
    return REQ.packages[pkg]


def install_guards() -> None:
    xacro.parse = guarded_parse
    xacro.open = guarded_open
    xacro.process_include = _locate(_bounded_include(xacro.process_include))
    xacro.handle_macro_call = _locate(_bounded_macro(xacro.handle_macro_call))
    for name in ("eval_all", "grab_property", "grab_macro", "check_attrs"):
        setattr(xacro, name, _locate(getattr(xacro, name)))
    substitution_args._eval = _no_eval
    substitution_args._eval_env = _no_env
    substitution_args._eval_optenv = lambda name, default="": default
    substitution_args._eval_find = _find
    substitution_args._eval_dict.update(env=_no_env, optenv=lambda name, default="": default, find=_find)


_BLOCKED_PREFIXES = ("subprocess.", "os.exec", "os.spawn", "os.posix_spawn", "os.system", "os.fork", "os.kill",
                     "socket.", "ctypes.", "os.remove", "os.rename", "os.rmdir", "os.mkdir", "os.chmod", "os.chown",
                     "os.symlink", "os.link", "os.truncate", "os.putenv", "os.unsetenv", "shutil.", "sys._getframe",
                     "import", "urllib.", "http.", "webbrowser.", "code.", "pdb.")


def audit(event: str, args: tuple) -> None:
    """Refuse what expansion never needs, whatever code asks for it (set after every import is done)."""
    if event == "open":
        path, mode, flags = args
        if isinstance(path, int):
            return
        if not isinstance(path, (str, bytes)):  # a PathLike's __fspath__ could answer differently when opened
            raise PermissionError("xacro expansion opens files by name only")
        if (mode and any(c in mode for c in "wax+")) or (flags or 0) & (os.O_WRONLY | os.O_RDWR | os.O_CREAT | os.O_TRUNC):
            raise PermissionError("xacro expansion may not write files")
        if not REQ.inside(os.fsdecode(path)):
            raise PermissionError(f"reading {os.path.basename(os.fsdecode(path))} is outside the allowed directories")
    elif event in ("os.listdir", "os.scandir", "glob.glob"):
        if args and args[0] is not None and not REQ.inside(os.fsdecode(args[0])):
            raise PermissionError("listing directories outside the allowed ones")
    elif event.startswith(_BLOCKED_PREFIXES):
        raise PermissionError(f"{event} is not allowed during xacro expansion")


def expand(req: Request) -> str:
    xacro.init_stacks(os.path.join(req.main_dir, req.name) if req.main_dir else None)
    doc = parse_text(req.text, req.name)
    xacro.all_includes = []
    xacro.process_doc(doc, mappings=dict(req.args), verbosity=0)
    out = doc.toprettyxml(indent="  ")
    if len(out.encode()) > req.max_bytes:
        raise Disallowed(f"the expanded URDF is larger than the {req.max_bytes} byte limit")
    return out


def describe(e: BaseException) -> str:
    where = WHERE.get(e)
    if isinstance(wrapped := getattr(e, "exc", None), Disallowed):  # xacro wraps what its substitutions raise
        e = wrapped
    if isinstance(e, Disallowed):
        message = str(e)
    elif isinstance(e, RecursionError):
        message = "expansion nested too deeply (a recursive macro or property?)"
    elif isinstance(e, MemoryError):
        message = "expansion needs more memory than allowed (an expression or macro that grows without bound?)"
    elif isinstance(e, xml.parsers.expat.ExpatError):
        return f"{xacro.filestack[-1] if xacro.filestack else REQ.name}:{e.lineno}: not well-formed XML: {e}"
    else:
        message = " ".join((str(e) or type(e).__name__).split())
        macros = [m.body.getAttribute("name") for m in (xacro.macrostack or []) if m.body is not None]
        if macros:
            message += f" (in macro {' <- '.join(reversed(macros))})"
    return f"{where[0]}:{where[1]}: {message}" if where else f"{REQ.name}: {message}"


def cut(message: str, limit: int) -> str:
    """`message`, or as much of it as fits in `limit` characters with how long it was (as the server cuts
    the errors it keeps: kb_server.text.cut), so that a huge one never leaves this process whole."""
    if len(message) <= limit:
        return message
    note = f"... [cut: {len(message):,} characters in all]"
    return message[:max(limit - len(note), 0)] + note


def main() -> int:
    global REQ
    limits = json.loads(sys.argv[1])
    mem = limits["memory"]
    resource.setrlimit(resource.RLIMIT_AS, (mem, mem))
    resource.setrlimit(resource.RLIMIT_CPU, (limits["cpu"], limits["cpu"] + 1))
    resource.setrlimit(resource.RLIMIT_FSIZE, (0, 0))
    os.nice(19)  # a document that burns its CPU seconds does so behind every request of the server
    REQ = Request(json.loads(sys.stdin.read()))
    install_guards()
    sys.setrecursionlimit(3000)
    sys.addaudithook(audit)
    try:
        result = {"urdf": expand(REQ)}
    except Exception as e:  # everything becomes a message for the parent
        result = {"error": cut(describe(e), REQ.max_error)}
    sys.stdout.buffer.write(json.dumps(result, ensure_ascii=False).encode("utf-8", "replace"))
    return 0


if __name__ == "__main__":
    sys.exit(main())
