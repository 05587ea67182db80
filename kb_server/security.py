"""What the server refuses from strangers, and the startup options that open it.

- `Host` must name this server (DNS rebinding): loopback names on a loopback bind, the bound
  address otherwise, any IP literal on a wildcard bind, plus `--allowed-host` names.
- Writes cannot come from another site: a request with an `Origin` other than the one it was
  sent to, or `Sec-Fetch-Site: cross-site/same-site`, is refused for every method but GET/HEAD/
  OPTIONS; and a POST that a page could send without a CORS preflight (text/plain, form or
  multipart body, no Authorization or X-Requested-With header) must show it comes from our own
  pages by its `Origin` or `Sec-Fetch-Site: same-origin`.
- Pipeline settings over HTTP: `model` only names a .gguf file in `--model-dir`, `llm_url` only
  one of the `--allow-llm-url` base URLs (http or https); `llm_model`, stored with the robot, is text
  without control characters.
- A non-loopback bind needs a token (or the loud `--insecure-no-token`).
"""
from __future__ import annotations

import ipaddress
import logging
import urllib.parse
from collections.abc import Iterable
from dataclasses import replace
from pathlib import Path

from flask import Flask, request

from urdfkb.kb_server.errors import BadRequest, Forbidden
from urdfkb.kb_server.text import check_text
from urdfkb.pipeline.errors import SettingsError, UrdfkbError
from urdfkb.pipeline.runner import Settings
from urdfkb.settings import HOST

log = logging.getLogger(__name__)

LOOPBACK_NAMES = ("127.0.0.1", "localhost", "::1")
WILDCARD = ("", "0.0.0.0", "::")
SAFE_METHODS = ("GET", "HEAD", "OPTIONS")
# What a page on another site can POST without a CORS preflight (Fetch standard, "CORS-safelisted").
SIMPLE_TYPES = ("", "text/plain", "application/x-www-form-urlencoded", "multipart/form-data")
PREFLIGHTED_HEADERS = ("Authorization", "X-Requested-With")
MAX_LISTED = 20


def is_loopback(host: str) -> bool:
    if host.lower() == "localhost":
        return True
    try:
        return ipaddress.ip_address(host.strip("[]")).is_loopback
    except ValueError:
        return False


def check_bind(host: str, token: str | None, insecure_no_token: bool = False) -> None:
    """Refuse to serve beyond this machine without a token, unless explicitly told to."""
    if is_loopback(host) or token:
        return
    if not insecure_no_token:
        raise UrdfkbError(
            f"refusing to serve on {host or 'all interfaces'} without a token: anyone who can reach it could "
            "populate robots. Pass --token T (or set URDFKB_TOKEN), or --insecure-no-token to serve anyway")
    log.warning("SERVING ON %s WITH NO TOKEN (--insecure-no-token): anyone who can reach this port can "
                "populate and replace robots", host or "all interfaces")


def _split_host(value: str) -> tuple[str, int | None] | None:
    """(lower-case host name without brackets, port or None) of a Host header or netloc; None if malformed."""
    try:
        parts = urllib.parse.urlsplit("//" + value)
        port = parts.port
    except ValueError:
        return None
    if not parts.hostname or parts.username is not None or parts.password is not None or parts.path:
        return None
    return parts.hostname.lower(), port


def _is_ip(name: str) -> bool:
    try:
        ipaddress.ip_address(name)
        return True
    except ValueError:
        return False


def _llm_base(url: str) -> str:
    return url.strip().rstrip("/")


class Policy:
    """The request checks of one server; `port` is the bound port, known after binding (None = any)."""

    def __init__(self, bind_host: str = HOST, port: int | None = None, allowed_hosts: Iterable[str] = (),
                 model_dir: str | Path | None = None, llm_urls: Iterable[str] = ()):
        self.bind_host = bind_host.strip("[]").lower()
        self.port = port or None
        self.allowed_hosts = []
        for entry in allowed_hosts:
            split = _split_host(entry)
            if split is None:
                raise UrdfkbError(f"--allowed-host {entry!r} is not a host name or host:port")
            self.allowed_hosts.append(split)
        self.model_dir = Path(model_dir).resolve() if model_dir else None
        if self.model_dir and not self.model_dir.is_dir():
            raise UrdfkbError(f"--model-dir {model_dir}: not a directory")
        self.llm_urls = []
        for url in llm_urls:
            parts = urllib.parse.urlsplit(url.strip())
            if parts.scheme not in ("http", "https") or not parts.hostname or parts.query or parts.fragment \
                    or parts.username is not None:
                raise UrdfkbError(f"--allow-llm-url {url!r}: give an http:// or https:// base URL with a host "
                                  "and no credentials, query or fragment")
            self.llm_urls.append(_llm_base(url))

    def install(self, app: Flask) -> None:
        """Check every request before its route runs (a refusal is raised, answered as any UrdfkbError)."""
        @app.before_request
        def check_request() -> None:
            self.check_host(request.headers.get("Host", ""))
            if request.method not in SAFE_METHODS:
                self.check_write()

    # --- Host -----------------------------------------------------------------------------

    def host_allowed(self, value: str) -> bool:
        split = _split_host(value)
        if split is None:
            return False
        name, port = split
        for allowed_name, allowed_port in self.allowed_hosts:
            if name == allowed_name and allowed_port in (None, port or 80):
                return True
        if self.port is not None and (port or 80) != self.port:
            return False
        if is_loopback(self.bind_host):
            return name in LOOPBACK_NAMES or name == self.bind_host
        if self.bind_host in WILDCARD:
            return name == "localhost" or _is_ip(name)
        return name == self.bind_host

    def check_host(self, value: str) -> None:
        if not self.host_allowed(value):
            raise BadRequest("the Host header does not name this server (a guard against DNS rebinding); "
                             "start it with --allowed-host NAME to answer to another name")

    # --- cross-site writes ----------------------------------------------------------------

    def check_write(self) -> None:
        """Refuse a state-changing request a page on another site could have sent."""
        origin = request.headers.get("Origin")
        site = request.headers.get("Sec-Fetch-Site")
        if refusal := self.cross_site(request.method, origin, site, request.headers.get("Host", "")):
            raise Forbidden(refusal)
        if request.blueprint == "sparql":
            return  # a query changes nothing; an update needs the token, i.e. an Authorization header
        if request.method == "POST" and request.mimetype in SIMPLE_TYPES and origin is None and site != "same-origin" \
                and not any(h in request.headers for h in PREFLIGHTED_HEADERS):
            raise Forbidden(f"a POST with Content-Type {request.mimetype or '(none)'} and no Origin could come from "
                            "any web page: send the URDF as application/xml, or add the header X-Requested-With "
                            "(or the token)")

    def cross_site(self, method: str, origin: str | None, site: str | None, host: str) -> str | None:
        """Why a write with these `Origin`, `Sec-Fetch-Site` and `Host` headers is refused as another site's, or None."""
        if origin is not None and not self._own_origin(origin, host):
            return f"cross-origin {method} refused: the request's Origin is not this server's"
        if site in ("cross-site", "same-site"):
            return f"cross-site {method} refused (Sec-Fetch-Site: {site})"
        return None

    def _own_origin(self, origin: str, host: str) -> bool:
        parts = urllib.parse.urlsplit(origin)
        if parts.scheme not in ("http", "https") or parts.path or parts.query:
            return False  # "null" (sandboxed pages, file:) and anything malformed
        if parts.netloc.lower() == host.lower():
            return True
        split = _split_host(parts.netloc)
        return split is not None and any(split[0] == n and p in (None, split[1] or 80) for n, p in self.allowed_hosts)

    # --- pipeline settings ----------------------------------------------------------------

    def check_settings(self, settings: Settings) -> Settings:
        """The settings with `model` resolved in the model directory; Forbidden (or BadRequest, for a model
        the directory does not hold) for what is not allowed, SettingsError for an `llm_model` no export could carry."""
        if settings.llm_model:
            try:
                check_text("llm_model", settings.llm_model)
            except ValueError as e:
                raise SettingsError(str(e)) from None
        if settings.model:
            settings = replace(settings, model=str(self._model_path(settings.model)))
        if settings.llm_url:
            if not self.llm_urls:
                raise Forbidden("setting llm_url is disabled on this server: the operator can allow LLM "
                                "servers with `urdfkb serve --allow-llm-url URL`")
            if _llm_base(settings.llm_url) not in self.llm_urls:
                raise Forbidden(f"llm_url is not one of the LLM servers this server allows: {', '.join(self.llm_urls)}")
        return settings

    def _model_path(self, name: str) -> Path:
        if self.model_dir is None:
            raise Forbidden("setting model is disabled on this server: the operator can offer the GGUF files "
                            "of one directory with `urdfkb serve --model-dir DIR`")
        available = sorted(p.name for p in self.model_dir.glob("*.gguf") if p.is_file())
        if name not in available:  # a bare file name only: no path of any kind reaches the file system
            listed = ", ".join(available[:MAX_LISTED]) + (", ..." if len(available) > MAX_LISTED else "")
            raise BadRequest("model must be the file name of a GGUF file in the server's model directory; "
                             f"available: {listed or 'none'}")
        return self.model_dir / name
