"""The viewer's HTTP server (Python stdlib ``http.server``): the page, its script and style, and
a small JSON API over :mod:`mlayer.viewer.session`.

Routes (GET only; every other path is 404, no path from a request ever reaches the file
system: the static files are a fixed table, clips are addressed by their index on the command
line)::

    /                    the page (index.html)
    /viewer.js, /viewer.css
    /api/clips           the clips: name, frames, fps, or the error that stopped them
    /api/clip?clip=I     the original: skeleton, positions, contacts, metrics
    /api/process?clip=I&alpha=..&arms=..&legs=..&spine=..&denoise=0|1&contacts=0|1
                 &length=SECONDS&fps=..&warp=..&joint=J
                         the processed motion (same fields), metrics and the layer chart data
    /api/download?...    the processed motion as a BVH attachment (same parameters)
    /api/layers.png?clip=I  the layer figure of `mlayer layers` (matplotlib)

Errors are JSON ``{"error": message}``: 400 for a bad or unknown parameter, 404 for an unknown
clip or path, 409 for a clip that failed to load, 500 for a failure inside mlayer (also printed
on stderr).
"""
from __future__ import annotations

import ipaddress
import json
import math
import sys
import threading
import traceback
from http.server import BaseHTTPRequestHandler, ThreadingHTTPServer
from importlib import resources
from urllib.parse import urlsplit

from ..errors import Error
from .session import PARAMS, Clip, ParamError, load_clips, parse_params

__all__ = ["ViewerServer", "make_server", "is_loopback"]

_STATIC = {  # URL path -> (package file, content type)
    "/": ("index.html", "text/html; charset=utf-8"),
    "/index.html": ("index.html", "text/html; charset=utf-8"),
    "/viewer.js": ("viewer.js", "text/javascript; charset=utf-8"),
    "/viewer.css": ("viewer.css", "text/css; charset=utf-8"),
}
_PROCESS_KEYS = tuple(PARAMS)
_CSP = ("default-src 'none'; script-src 'self'; style-src 'self'; img-src 'self' data:; "
        "connect-src 'self'; base-uri 'none'; form-action 'none'; frame-ancestors 'none'")


def is_loopback(host: str) -> bool:
    """True for localhost and loopback addresses (127.0.0.0/8, ::1)."""
    if host.lower() == "localhost":
        return True
    try:
        return ipaddress.ip_address(host.strip("[]")).is_loopback
    except ValueError:
        return False


def _static(name: str) -> bytes:
    return (resources.files(__package__) / name).read_bytes()


def _json_default(o):
    raise TypeError(f"not JSON serializable: {type(o).__name__}")


def _clean(o):
    """JSON has no NaN/inf: map them to null."""
    if isinstance(o, float):
        return o if math.isfinite(o) else None
    if isinstance(o, dict):
        return {k: _clean(v) for k, v in o.items()}
    if isinstance(o, list):
        return [_clean(v) for v in o]
    return o


class ViewerServer(ThreadingHTTPServer):
    """A ThreadingHTTPServer holding the clips; ``url`` is the address to open."""

    daemon_threads = True
    allow_reuse_address = True

    def __init__(self, clips: list[Clip], host: str = "127.0.0.1", port: int = 0, *,
                 log=None):
        self.clips = clips
        self.log = log or sys.stderr
        self._log_lock = threading.Lock()
        family_v6 = ":" in host
        if family_v6:
            import socket
            self.address_family = socket.AF_INET6
        super().__init__((host.strip("[]"), port), _Handler)
        self.host = host
        port = self.server_address[1]
        shown = f"[{host.strip('[]')}]" if family_v6 else host
        self.url = f"http://{shown}:{port}/"
        # DNS rebinding guard: on loopback, only requests naming a loopback host are served
        self.allowed_hosts = None
        if is_loopback(host):
            self.allowed_hosts = {f"{h}:{port}" for h in ("127.0.0.1", "localhost", "[::1]",
                                                         shown)}

    def warm(self) -> threading.Thread:
        """Decompose every clip in a background thread, so the first slider move is fast."""
        def run():
            for c in self.clips:
                try:
                    c.warm()
                except Exception as e:  # reported again when the page asks for the clip
                    self.say(f"mlayer view: error: {c.path}: {e}")
        t = threading.Thread(target=run, name="mlayer-view-warm", daemon=True)
        t.start()
        return t

    def say(self, text: str) -> None:
        with self._log_lock:
            print(text, file=self.log, flush=True)


def make_server(paths, host: str = "127.0.0.1", port: int = 0, *, log=None) -> ViewerServer:
    """Load the clips (a failing clip keeps its error) and bind the server (not started:
    call ``serve_forever()``, in a thread if needed; ``shutdown()`` stops it)."""
    return ViewerServer(load_clips(paths), host, port, log=log)


class _Handler(BaseHTTPRequestHandler):
    server: ViewerServer
    server_version = "mlayer-view"
    protocol_version = "HTTP/1.1"

    def log_message(self, fmt, *args):  # quiet: errors are reported by _fail
        pass

    # -- responses --

    def _send(self, status: int, body: bytes, ctype: str, extra=None) -> None:
        self.send_response(status)
        self.send_header("Content-Type", ctype)
        self.send_header("Content-Length", str(len(body)))
        self.send_header("Cache-Control", "no-store")
        self.send_header("X-Content-Type-Options", "nosniff")
        self.send_header("Content-Security-Policy", _CSP)
        self.send_header("Referrer-Policy", "no-referrer")
        for k, v in (extra or {}).items():
            self.send_header(k, v)
        self.end_headers()
        if self.command != "HEAD":
            self.wfile.write(body)

    def _json(self, obj, status: int = 200) -> None:
        body = json.dumps(_clean(obj), separators=(",", ":"), allow_nan=False,
                          default=_json_default).encode()
        self._send(status, body, "application/json")

    def _fail(self, status: int, message: str) -> None:
        if status >= 500:
            self.server.say(f"mlayer view: error: {message}")
        self._json({"error": message}, status)

    # -- routing --

    def do_GET(self):  # noqa: N802 (http.server's naming)
        try:
            self._route()
        except ParamError as e:
            self._fail(e.status, str(e))
        except Error as e:  # mlayer rejected the values (e.g. a resampling factor over 100x)
            self._fail(400, str(e))
        except (BrokenPipeError, ConnectionResetError):
            pass
        except Exception as e:  # a bug: report it, keep serving
            traceback.print_exc(file=self.server.log)
            self._fail(500, f"{type(e).__name__}: {e}")

    do_HEAD = do_GET

    def _route(self) -> None:
        allowed = self.server.allowed_hosts
        if allowed is not None and self.headers.get("Host", "") not in allowed:
            raise ParamError(f"unexpected Host header {self.headers.get('Host')!r}", 403)
        url = urlsplit(self.path)
        path = url.path
        if path in _STATIC:
            if url.query:
                raise ParamError(f"{path} takes no parameters")
            name, ctype = _STATIC[path]
            self._send(200, _static(name), ctype)
            return
        api = {"/api/clips": self._clips, "/api/clip": self._clip,
               "/api/process": self._process, "/api/download": self._download,
               "/api/layers.png": self._layers_png}.get(path)
        if api is None:
            raise ParamError(f"no such page: {path[:200]}", 404)
        api(url.query)

    def _clip_of(self, p: dict) -> Clip:
        i = p["clip"]
        if i is None:
            raise ParamError("missing parameter 'clip' (the clip's index)")
        clips = self.server.clips
        if not 0 <= i < len(clips):
            raise ParamError(f"no clip {i}: the server has {len(clips)} clip(s), "
                             f"0 to {len(clips) - 1}", 404)
        c = clips[i]
        if not c.ok:
            raise ParamError(f"clip {i} failed to load: {c.error}", 409)
        return c

    def _clips(self, query: str) -> None:
        parse_params(query, ())
        self._json({"clips": [c.summary() for c in self.server.clips]})

    def _clip(self, query: str) -> None:
        self._json(self._clip_of(parse_params(query, ("clip",))).original())

    def _process(self, query: str) -> None:
        p = parse_params(query, _PROCESS_KEYS)
        data, _ = self._clip_of(p).process(p)
        self._json(data)

    def _download(self, query: str) -> None:
        p = parse_params(query, _PROCESS_KEYS)
        name, text = self._clip_of(p).download(p)
        self._send(200, text.encode(), "application/octet-stream",
                   {"Content-Disposition": f'attachment; filename="{_ascii(name)}"'})

    def _layers_png(self, query: str) -> None:
        c = self._clip_of(parse_params(query, ("clip",)))
        try:
            png = c.layers_png()
        except ImportError as e:
            raise ParamError(f"the layer figure needs matplotlib: {e}", 503) from None
        self._send(200, png, "image/png")


def _ascii(name: str) -> str:
    return "".join(ch if ch.isascii() and (ch.isalnum() or ch in "._-") else "_" for ch in name)
