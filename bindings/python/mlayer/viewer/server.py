"""The viewer's HTTP server (Python stdlib ``http.server``): the page, its script and style, and
a small JSON API over :mod:`mlayer.viewer.session`.

Routes (GET and HEAD only; every other path is 404, no path from a request ever reaches the
file system: the static files are a fixed table, clips are addressed by their index on the
command line)::

    /                    the page (index.html, with this server's session token)
    /viewer.js, /viewer.css
    /api/clips           the clips: name, frames, fps, or the error that stopped them
    /api/clip?clip=I     the original: skeleton, positions, contacts, metrics
    /api/process?clip=I&alpha=..&arms=..&legs=..&spine=..&denoise=0|1&contacts=0|1
                 &length=SECONDS&fps=..&warp=..&joint=J
                         the processed motion (same fields), metrics and the layer chart data
    /api/download?...    the processed motion as a BVH attachment (same parameters)
    /api/layers.png?clip=I  the layer figure of `mlayer layers` (matplotlib)
    /api/manifold[?train=1]  the motion manifold of the clips (mlayer.viewer.manifold): its
                         state and training progress (train=1 starts the training in the
                         background); when learned, the lattice, trajectories, primitives
                         and transition matrix
    /api/manifold/motion?points=R,C;..|keys=CLIP:FRAME,..|start=CLIP:FRAME&chain=..
                 &noise=..&seed=..&frames=N&guards=0|1
                         a motion on the manifold: its figure data, path and primitives
    /api/manifold/download?...  that motion as a BVH attachment

Errors are JSON ``{"error": message}``: 400 for a bad or unknown parameter, 403 for a request
from another site or without the session token, 404 for an unknown clip or path, 409 for a
clip that failed to load (or a manifold motion before the manifold is learned), 413 for a
request over the output limit (or with a body), 500 for a failure inside mlayer (also printed
on stderr).

Limits (options of :class:`ViewerServer`, and of ``mlayer view``):

- ``max_values``: one request may produce at most this many frames x points (joints and End
  Sites) out, checked from the parameters before any work (413, saying which frame count fits);
  a clip is always served at its own size.
- ``manifold_frames``: the most training frames of the manifold (the clips decimated by one
  stride; frames x points also within ``max_values``).
- ``cache_bytes``: the processed motions and encoded answers kept, by bytes (LRU).
- Every ``/api/`` request needs the session token, a random string made when the server starts
  and embedded in the page (``<meta name="mlayer-token">``): the page's script sends it in the
  ``X-Mlayer-Token`` header (or ``token=`` in the query, for links and images). Requests with an
  ``Origin`` other than the server's own or ``Sec-Fetch-Site: cross-site`` are refused (and
  ``same-site`` on the API: another port of localhost is the same site), as are requests naming
  a host the server does not serve under (DNS rebinding: the bound address, the loopback names,
  on a wildcard address this machine's name and addresses, and ``allow_hosts``) and requests
  with more than one Host header.
- ``threads`` workers serve the requests (a bounded pool, not a thread per connection); the
  listen backlog is :data:`BACKLOG`. One watcher thread holds the connections while a request
  arrives and while an answer is taken (:mod:`mlayer.viewer._net`): a worker gets only
  requests that arrived whole, and leaves what the client does not read at once to the watcher.
- At most ``max_connections`` connections are open at once (:data:`DEFAULT_MAX_CONNECTIONS`);
  one more is answered 503 and closed at once.
- ``timeout``: a request (line, headers, body) must arrive whole within ``timeout`` seconds of
  the accept, or of the end of the previous answer on a kept-alive connection; a connection
  idle or trickling that long is closed without taking a worker. An answer must be taken whole
  within ``timeout`` seconds of its first byte, then the connection is closed.
- The request line and headers are read up to 128 KiB (431 beyond, closed); a line over 64 KiB
  is 414 or 431, as in ``http.server``. Unsent answers are queued up to :data:`MAX_QUEUED`
  bytes over all connections; beyond, a worker writes the answer itself (within the same
  deadline).
- A GET or HEAD with a body: a ``Content-Length`` up to 64 KiB is read and ignored, a larger
  one or a ``Transfer-Encoding`` is refused (413 / 400) and the connection closed, so a body is
  never read as a second request. Other methods: 405, connection closed.
"""
from __future__ import annotations

import hmac
import ipaddress
import math
import os
import secrets
import socket
import sys
import threading
import traceback
from collections.abc import Iterable
from http.server import BaseHTTPRequestHandler, HTTPServer
from importlib import resources
from typing import IO, Any, cast
from urllib.parse import unquote, urlsplit

from ..errors import Error, InvalidArgumentError
from . import _net
from ._net import MAX_BODY, Conn, Pool, Reactor, WriteBudget, body_size
from .manifold import DEFAULT_MANIFOLD_FRAMES, ManifoldSession
from .session import (DEFAULT_CACHE_BYTES, DEFAULT_MAX_VALUES, PARAMS, ViewerClip, ParamError,
                      ResultCache, json_bytes, load_clips, parse_params)

__all__ = ["ViewerServer", "make_server", "is_loopback", "BACKLOG", "DEFAULT_MAX_VALUES",
           "DEFAULT_CACHE_BYTES", "DEFAULT_TIMEOUT", "DEFAULT_THREADS",
           "DEFAULT_MANIFOLD_FRAMES", "DEFAULT_MAX_CONNECTIONS"]

#: the listen queue (the kernel caps it at net.core.somaxconn)
BACKLOG = 1024
DEFAULT_TIMEOUT = 10.0   # seconds
DEFAULT_THREADS = 8
MAX_PENDING = 1024       # connections with a request waiting for a worker
#: connections open at once (each may hold up to 192 KiB of request in the watcher); beyond,
#: a new one is answered 503 and closed
DEFAULT_MAX_CONNECTIONS = 1024
#: bytes of answers not yet taken by their clients, over all connections, the watcher queues
MAX_QUEUED = 256 << 20
_TOKEN_HEADER = "X-Mlayer-Token"
_TOKEN_META = b'<meta name="mlayer-token" content="">'

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
    """Whether a host is this machine's loopback.

    Parameters
    ----------
    host : str
        A host name or address (IPv6 in brackets or not).

    Returns
    -------
    bool
        True for localhost and loopback addresses (127.0.0.0/8, ::1).
    """
    if host.lower() == "localhost":
        return True
    try:
        return ipaddress.ip_address(host.strip("[]")).is_loopback
    except ValueError:
        return False


def _static(name: str) -> bytes:
    return (resources.files(__package__) / name).read_bytes()


def _served_hosts(host: str, shown: str, port: int, extra: Iterable[str]) -> set[str]:
    """The Host headers a server bound to host:port answers: its own address and the loopback
    names; on a wildcard address, this machine's name and addresses too; plus extra (names,
    or name:port). Port 80 may go without the port, as browsers send it."""
    names = {"127.0.0.1", "localhost", "[::1]", shown}
    if host.strip("[]") in ("0.0.0.0", "::", ""):
        try:
            hn = socket.gethostname()
            names.add(hn)
            names.update(socket.gethostbyname_ex(hn)[2])
        except OSError:
            pass
    out: set[str] = set()
    for h in extra:
        if not isinstance(h, str) or not h or any(c.isspace() for c in h) or "/" in h:
            raise InvalidArgumentError(f"allow_hosts (--allow-host of mlayer view): {h!r} is "
                                       "not a host name")
        if h.rsplit(":", 1)[-1].isdigit() and not h.endswith("]"):
            out.add(h)
        else:
            names.add(h)
    for n in names:
        n = f"[{n}]" if ":" in n and not n.startswith("[") else n
        out.add(f"{n}:{port}")
        if port == 80:
            out.add(n)
    return out


class ViewerServer(HTTPServer):
    """An HTTP server holding the clips.

    ``url`` is the address to open, ``token`` the session token the page carries. See the
    module's doc for the limits. Requests are served by a pool of ``threads`` workers;
    ``serve_forever()`` runs the accept loop (``shutdown()`` stops it, ``server_close()``
    releases everything).

    Parameters
    ----------
    clips : list of ViewerClip
        The clips (:func:`mlayer.viewer.load_clips`).
    host : str, optional
        The address to bind.
    port : int, optional
        The port (0: any free one).
    log : text stream, optional
        Where the server's lines go (default stderr).
    max_values : int, optional
        Cap on the frames x points of one request's output.
    cache_bytes : int, optional
        Size of the shared result cache.
    timeout : float, optional
        Seconds a client may take to send a request (from its connect, or from the previous
        answer), and to take an answer.
    threads : int, optional
        Worker threads.
    manifold_frames : int, optional
        The most training frames of the manifold page.
    allow_hosts : iterable of str, optional
        More names (or ``name:port``) the page may be requested under, as the Host header
        gives them. Served without them: the bound address, and the loopback names; bound to
        a wildcard address (``0.0.0.0``, ``::``), also this machine's host name and its
        addresses. Any other Host is refused (403): a DNS-rebinding page names its own.
    max_connections : int, optional
        Connections open at once; a connection beyond is answered 503 and closed (a flood of
        slow connections would otherwise hold up to 192 KiB each until its deadline).
    rename : dict of str to str, optional
        Joint names of another naming scheme mapped to the first clip's, for the manifold's
        training (:class:`mlayer.viewer.manifold.ManifoldSession`).
    """
    address_family: socket.AddressFamily
    max_values: int
    cache: ResultCache
    timeout: float
    threads: int
    log: IO[str]
    manifold: ManifoldSession
    token: str
    url: str

    allow_reuse_address = True
    request_queue_size = BACKLOG

    def __init__(self, clips: list[ViewerClip], host: str = "127.0.0.1", port: int = 0, *,
                 log: IO[str] | None = None, max_values: int = DEFAULT_MAX_VALUES,
                 cache_bytes: int = DEFAULT_CACHE_BYTES, timeout: float = DEFAULT_TIMEOUT,
                 threads: int = DEFAULT_THREADS,
                 manifold_frames: int = DEFAULT_MANIFOLD_FRAMES,
                 allow_hosts: Iterable[str] = (),
                 max_connections: int = DEFAULT_MAX_CONNECTIONS,
                 rename: dict[str, str] | None = None) -> None:
        self.max_values = _int_option("max_values", max_values, 1000)
        self.cache = ResultCache(_int_option("cache_bytes", cache_bytes, 0))  # --cache-mb
        if not (isinstance(timeout, (int, float)) and math.isfinite(timeout) and
                0 < timeout <= 86400):
            raise InvalidArgumentError(f"timeout (--timeout of mlayer view) must be a number of "
                                       f"seconds in (0, 86400], got {timeout!r}")
        self.timeout = float(timeout)
        self.threads = _int_option("threads", threads, 1, 256)
        self.clips = clips
        for c in clips:
            c.cache, c.max_values = self.cache, self.max_values
        self.log = log or sys.stderr
        self.manifold = ManifoldSession(
            clips, cache=self.cache, max_values=self.max_values, log=self.log,
            max_frames=_int_option("manifold_frames", manifold_frames, 16, 1_000_000),
            rename=rename)
        self.token = secrets.token_urlsafe(24)
        self._log_lock = threading.Lock()
        self._page: bytes | None = None
        self._reactor: Reactor | None = None
        self._pool = Pool(self._serve_conn, self.threads, MAX_PENDING)
        self._budget = WriteBudget(MAX_QUEUED)
        self._open = WriteBudget(_int_option("max_connections", max_connections, 1, 1 << 20))
        self._start_lock = threading.Lock()
        self._closing = False
        family_v6 = ":" in host
        if family_v6:
            self.address_family = socket.AF_INET6
        super().__init__((host.strip("[]"), port), _Handler)
        self.host = host
        port = self.server_address[1]
        shown = f"[{host.strip('[]')}]" if family_v6 else host
        self.url = f"http://{shown}:{port}/"
        # DNS rebinding guard: only requests naming this server are served (a rebinding
        # page's requests name the page's own host)
        self.allowed_hosts: set[str] = _served_hosts(host, shown, port, allow_hosts)

    # -- connections: accepted -> watcher (until a request is in) -> pool -> watcher (the
    #    rest of the answer, the next request) or closed --

    def process_request(self, request: Any, client_address: Any) -> None:
        """Hand an accepted connection to the watcher (the reactor), started on first use.

        Parameters
        ----------
        request : socket.socket
            The connection.
        client_address : tuple
            The peer's address.
        """
        with self._start_lock:
            if self._reactor is None:
                self._reactor = Reactor(self._dispatch, self.timeout)
                self._reactor.start()
            reactor = self._reactor
        if not self._open.take(1):
            _net.refuse_busy(request)
            return
        reactor.add(Conn(request, client_address, self.timeout, self._budget,
                         self._open))

    def _dispatch(self, conn: Conn) -> None:
        if self._closing or not self._pool.submit(conn):
            conn.refuse_busy()

    def _serve_conn(self, conn: Conn) -> None:
        """One worker's turn on a connection: its request (whole, the watcher waited for it)
        and the pipelined ones already whole after it, while each answer went out whole; then
        back to the watcher (the rest of the answer, the next request) or closed."""
        try:
            while True:
                conn.wfile.start()
                h = _Handler(cast(Any, conn), conn.addr, self)
                if conn.wfile.broken or self._closing:
                    conn.close(abort=conn.wfile.broken)
                    return
                if h.close_connection:
                    if not conn.wfile.out:
                        conn.close()
                        return
                    conn.closing = True   # once the answer is out
                    break
                if conn.wfile.out or conn.rfile.state() != _net.READY:
                    break
            assert self._reactor is not None  # started by process_request
            self._reactor.resume(conn)
        except OSError:
            conn.close()
        except Exception:
            traceback.print_exc(file=self.log)
            conn.close()

    @property
    def n_workers(self) -> int:
        """Worker threads started (at most ``threads``)."""
        return self._pool.n_threads

    @property
    def n_idle(self) -> int:
        """Connections waiting in the watcher."""
        return 0 if self._reactor is None else self._reactor.n_idle

    def server_close(self) -> None:
        self._closing = True
        super().server_close()
        if self._reactor is not None:
            self._reactor.stop()
            self._reactor.join(5)
        self._pool.stop()

    # -- the page and the clips --

    def page(self) -> bytes:
        """The page.

        Returns
        -------
        bytes
            index.html with this server's token.
        """
        if self._page is None:
            html = _static("index.html")
            assert _TOKEN_META in html, "index.html lost its token meta tag"
            self._page = html.replace(_TOKEN_META, _TOKEN_META.replace(
                b'content=""', b'content="' + self.token.encode() + b'"'))
        return self._page

    def own_origins(self, host_header: str) -> set[str]:
        """The origins a request from the page itself carries.

        Parameters
        ----------
        host_header : str
            The request's Host header (it is one of the allowed hosts: the others are
            refused before).

        Returns
        -------
        set of str
            ``http://`` plus each allowed host.
        """
        return {f"http://{h}" for h in self.allowed_hosts}

    def warm(self) -> threading.Thread:
        """Decompose every clip in a background thread, so the first slider move is fast.

        Returns
        -------
        threading.Thread
            The started thread.
        """
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
        """Write a line to the server's log (one writer at a time).

        Parameters
        ----------
        text : str
            The line.
        """
        with self._log_lock:
            print(text, file=self.log, flush=True)


def _int_option(name: str, value, low: int, high: int | None = None) -> int:
    if isinstance(value, bool) or not isinstance(value, int) or value < low or \
            (high is not None and value > high):
        rng = f">= {low}" if high is None else f"in {low}..{high}"
        flag = "--" + name.replace("_", "-")
        raise InvalidArgumentError(f"{name} ({flag} of mlayer view) must be an integer {rng}, "
                                   f"got {value!r}")
    return value


def make_server(paths: Iterable[str | os.PathLike[str]], host: str = "127.0.0.1",
                port: int = 0, *, log: IO[str] | None = None, **limits: Any) -> ViewerServer:
    """Load the clips and bind the server (not started).

    Call ``serve_forever()``, in a thread if needed; ``shutdown()`` stops it. A failing clip
    keeps its error.

    Parameters
    ----------
    paths : iterable of str or os.PathLike
        The BVH files.
    host : str, optional
        The address to bind.
    port : int, optional
        The port (0: any free one).
    log : text stream, optional
        Where the server's lines go (default stderr).
    **limits
        ``max_values``, ``cache_bytes``, ``timeout``, ``threads``, ``manifold_frames``,
        ``allow_hosts``, ``max_connections``, ``rename`` (see :class:`ViewerServer`).

    Returns
    -------
    ViewerServer
        The bound server.
    """
    return ViewerServer(load_clips(paths), host, port, log=log, **limits)


class _Handler(BaseHTTPRequestHandler):
    """One request on a :class:`Conn` (the server's worker loop makes one per request)."""

    server: ViewerServer
    server_version = "mlayer-view"
    protocol_version = "HTTP/1.1"

    def setup(self):
        conn = self.request
        self.connection = conn.sock
        self.rfile = conn.rfile
        self.wfile = conn.wfile

    def parse_request(self) -> bool:
        """http.server's parse, refusing HTTP/0.9 ("GET /" alone): its answer would have no
        status line, and the header writes failed (no answer and a traceback on the server)."""
        raw = getattr(self, "raw_requestline", b"")  # (http.server sets it; no stub has it)
        words = str(raw, "iso-8859-1").rstrip("\r\n").split()
        if len(words) == 2:  # before http.server waits for headers HTTP/0.9 does not send
            self.requestline = " ".join(words)
            self.command, self.path = words[0], words[1]
            self.request_version = "HTTP/1.0"  # so that the answer has a status line
            self.close_connection = True
            self._fail(400, "HTTP/0.9 requests are not served: send HTTP/1.0 or 1.1", close=True)
            return False
        return super().parse_request()

    def handle(self):
        self.close_connection = True
        self.handle_one_request()

    def finish(self):
        pass

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
        if self.command == "HEAD":
            self.end_headers()
        elif len(body) <= 65536:  # one write (one packet) for the head and a small body
            # BaseHTTPRequestHandler's own header buffer (CPython; no stub declares it)
            self._headers_buffer.append(b"\r\n" + body)  # type: ignore[attr-defined]
            self.flush_headers()
        else:
            self.end_headers()
            self.wfile.write(body)

    def _json(self, obj, status: int = 200) -> None:
        self._send(status, json_bytes(obj), "application/json")

    def _fail(self, status: int, message: str, close: bool = False) -> None:
        if status >= 500:
            self.server.say(f"mlayer view: error: {message}")
        self._send(status, json_bytes({"error": message}), "application/json",
                   {"Connection": "close"} if close else None)

    # -- routing --

    def do_GET(self):  # noqa: N802 (http.server's naming)
        try:
            if not self._read_body():
                return
            self._route()
        except ParamError as e:
            self._fail(e.status, str(e))
        except Error as e:  # mlayer rejected the values
            self._fail(400, str(e))
        except (BrokenPipeError, ConnectionResetError, TimeoutError):
            self.close_connection = True
        except Exception as e:  # a bug: report it, keep serving
            traceback.print_exc(file=self.server.log)
            self._fail(500, f"{type(e).__name__}: {e}")

    do_HEAD = do_GET

    def _other(self):
        self._fail(405, f"the viewer answers GET and HEAD only, not {self.command}", close=True)

    do_POST = do_PUT = do_DELETE = do_PATCH = do_OPTIONS = _other

    def _read_body(self) -> bool:
        """Read and drop a small body of a GET / HEAD; refuse (and close) otherwise, so a body
        is never taken for the next request. False when refused."""
        n, why = body_size(self.headers)   # the watcher waited for the same n bytes
        if why == "transfer-encoding":
            self._fail(400, "a GET request takes no body (Transfer-Encoding is not accepted)",
                       close=True)
            return False
        if why == "bad-length":
            lengths = self.headers.get_all("Content-Length") or []
            self._fail(400, f"bad Content-Length {', '.join(lengths)[:100]!r}", close=True)
            return False
        if why == "too-large":
            self._fail(413, f"a GET request takes no body; got Content-Length {n} (at most "
                            f"{MAX_BODY} bytes are read and ignored)", close=True)
            return False
        if n == 0:
            return True
        got = self.rfile.read(n)
        if len(got) < n:
            self.close_connection = True
            return False
        return True

    def _check_site(self, api: bool) -> None:
        site = (self.headers.get("Sec-Fetch-Site") or "").strip().lower()
        if site == "cross-site" or (api and site == "same-site"):
            raise ParamError(f"refused a {site} request: the viewer answers only its own page "
                             f"({self.server.url})", 403)
        origin = self.headers.get("Origin")
        if origin is not None and origin not in self.server.own_origins(
                self.headers.get("Host", "")):
            raise ParamError(f"refused a request from the origin {origin[:100]!r}: the viewer "
                             f"answers only its own page ({self.server.url})", 403)

    def _take_token(self, query: str) -> str:
        """Check the session token (header or ``token=``); returns the query without it."""
        parts = query.split("&") if query else []
        given = [unquote(p[6:]) for p in parts if p.startswith("token=")]
        rest = "&".join(p for p in parts if not p.startswith("token="))
        header = self.headers.get(_TOKEN_HEADER)
        if header is not None:
            given.append(header.strip())
        if not given:
            raise ParamError(f"missing the session token: use the viewer from its page "
                             f"({self.server.url}); a script takes the token from the page's "
                             f'<meta name="mlayer-token"> and sends it as {_TOKEN_HEADER}', 403)
        want = self.server.token.encode()
        if len(given) > 2 or not all(
                hmac.compare_digest(g.encode("utf-8", "surrogateescape"), want) for g in given):
            raise ParamError("wrong session token: the server was restarted; reload the page "
                             f"({self.server.url})", 403)
        return rest

    def _route(self) -> None:
        hosts = self.headers.get_all("Host") or []
        if len(hosts) > 1:
            raise ParamError(f"{len(hosts)} Host headers: a request names one host", 400)
        if (hosts[0] if hosts else "") not in self.server.allowed_hosts:
            raise ParamError(f"unexpected Host header {self.headers.get('Host')!r}: this viewer "
                             f"serves {self.server.url} (mlayer view --allow-host NAME adds a "
                             "name)", 403)
        url = urlsplit(self.path)
        path = url.path
        self._check_site(path.startswith("/api/"))
        if path in _STATIC:
            if url.query:
                raise ParamError(f"{path} takes no parameters")
            name, ctype = _STATIC[path]
            self._send(200, self.server.page() if name == "index.html" else _static(name),
                       ctype)
            return
        api = {"/api/clips": self._clips, "/api/clip": self._clip,
               "/api/process": self._process, "/api/download": self._download,
               "/api/layers.png": self._layers_png, "/api/manifold": self._manifold,
               "/api/manifold/motion": self._manifold_motion,
               "/api/manifold/download": self._manifold_download}.get(path)
        if api is None:
            raise ParamError(f"no such page: {path[:200]}", 404)
        api(self._take_token(url.query))

    def _clip_of(self, p: dict) -> ViewerClip:
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
        body = self._clip_of(parse_params(query, ("clip",))).original_body()
        self._send(200, body, "application/json")

    def _process(self, query: str) -> None:
        p = parse_params(query, _PROCESS_KEYS)
        self._send(200, self._clip_of(p).process_body(p), "application/json")

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


    def _manifold(self, query: str) -> None:
        if query not in ("", "train=0", "train=1"):
            raise ParamError(f"/api/manifold takes only train=0 or train=1, got "
                             f"{query[:100]!r}")
        self._send(200, self.server.manifold.status(start=query == "train=1"),
                   "application/json")

    def _manifold_motion(self, query: str) -> None:
        self._send(200, self.server.manifold.motion(query)[0], "application/json")

    def _manifold_download(self, query: str) -> None:
        name, text = self.server.manifold.download(query)
        self._send(200, text.encode(), "application/octet-stream",
                   {"Content-Disposition": f'attachment; filename="{_ascii(name)}"'})


def _ascii(name: str) -> str:
    return "".join(ch if ch.isascii() and (ch.isalnum() or ch in "._-") else "_" for ch in name)
