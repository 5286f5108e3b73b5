"""The viewer's connection handling (stdlib only): one watcher thread (a selectors reactor)
that holds every connection while it is not being served, and a bounded pool of worker
threads that serve requests already received whole. A connection takes a worker only while a
request is computed and its answer handed over, never while a client is sending or reading.

- **Reading.** The watcher reads the request (request line, headers and the body its
  ``Content-Length`` announces, up to :data:`MAX_BODY`) without blocking, and hands the
  connection to the pool only once all of it is in. The whole request must arrive within
  ``timeout`` seconds of the accept (a fresh connection) or of the end of the previous answer
  (a kept-alive one); at that deadline the connection is closed, whether it sent nothing (the
  idle timeout) or trickled a byte at a time: a slowloris client never takes a worker. The
  body is read by the watcher too, not by the worker under the rest of the deadline: it is
  small (at most 64 KiB, anything larger is refused unread), and a worker waiting for a body
  that trickles would let a slow client hold it for the whole deadline again.
- **Limits of the request.** A line over 64 KiB or more than 100 header lines: the worker is
  given what arrived and ``http.server`` refuses it (414 / 431), as before. A head (request
  line and headers) over :data:`MAX_HEAD` bytes in lines that each fit: 431 from the watcher,
  closed. So a connection buffers at most about ``MAX_HEAD + MAX_BODY + 64 KiB``.
- **Pipelining.** Bytes after a request stay in the connection's buffer: a worker serves the
  next request at once if it is already whole (and the previous answer was sent whole), the
  watcher waits for the rest otherwise.
- **Writing.** An answer is sent without blocking; what the socket does not take at once is
  queued and written by the watcher as the client reads, and the worker moves on. The whole
  answer must be taken within ``timeout`` seconds of its first write (one deadline for the
  answer, not per piece); at that deadline the connection is closed. Nothing more is read from
  a connection until its answer is out, and a worker does not start the next pipelined request
  while an answer waits. The unsent answers of all connections are counted against one budget
  (``max_queued`` bytes; a cached answer shared by many connections counts once per
  connection): over it, the worker writes the answer itself, blocking, within the same
  deadline, so memory stays bounded and a worker is held at most ``timeout`` seconds.
- **Workers.** At most ``threads`` requests are served at a time, whatever the number of
  connections; up to ``max_pending`` more whole requests wait in the queue; beyond that a
  connection is answered 503 and closed.
"""
from __future__ import annotations

import collections
import http.client
import io
import queue
import selectors
import socket
import struct
import threading
import time

__all__ = ["Conn", "Reactor", "Pool", "refuse_busy", "WriteBudget", "body_size", "MAX_BODY",
           "MAX_HEAD"]

#: the longest line http.server and http.client read (the request line, each header line)
MAX_LINE = 65536
#: the most lines of headers http.client reads (the blank line that ends them included)
MAX_HEADER_LINES = getattr(http.client, "_MAXHEADERS", 100)
#: the largest request head (request line and headers) the watcher keeps; more: 431
MAX_HEAD = 128 << 10
#: the largest body of a GET or HEAD that is read (and ignored); more is refused unread
MAX_BODY = 65536

_RESET = struct.pack("ii", 1, 0)   # SO_LINGER on, 0 s: close resets
WAIT, READY, TOO_LARGE = 0, 1, 2   # what a connection's buffered bytes are (_Reader.state)


def _answer(status: bytes, message: bytes) -> bytes:
    body = b'{"error":"' + message + b'"}'
    return (b"HTTP/1.1 " + status + b"\r\nContent-Type: application/json\r\n"
            b"Connection: close\r\nContent-Length: %d\r\n\r\n" % len(body) + body)


_BUSY = _answer(b"503 Service Unavailable", b"the viewer is busy: too many connections are "
                b"waiting; retry, or start mlayer view with more --threads")
_TOO_LARGE = _answer(b"431 Request Header Fields Too Large", b"the request line and headers "
                     b"are over %d KiB" % (MAX_HEAD >> 10))


def body_size(headers) -> tuple[int, str | None]:
    """The body a GET or HEAD request announces, by its headers (one rule for the watcher,
    which waits for it, and the handler, which reads or refuses it).

    Parameters
    ----------
    headers : http.client.HTTPMessage
        The request's headers.

    Returns
    -------
    tuple of (int, str or None)
        ``(n, None)``: read ``n`` bytes of body (0: none). ``(n, why)``: refuse the request
        without reading a body, ``why`` being ``"transfer-encoding"``, ``"bad-length"`` (not
        one ASCII decimal number of at most 18 digits, or two different ones) or ``"too-large"``
        (``n`` over :data:`MAX_BODY`).
    """
    if headers.get("Transfer-Encoding") is not None:
        return 0, "transfer-encoding"
    lengths = [v.strip() for v in headers.get_all("Content-Length") or []]
    if not lengths:
        return 0, None
    v = lengths[0]
    if len(set(lengths)) != 1 or not (v.isascii() and v.isdigit()) or len(v) > 18:
        return 0, "bad-length"
    n = int(v)
    return (n, "too-large") if n > MAX_BODY else (n, None)


class _Reader:
    """The read side of a connection: the bytes received and not yet consumed (the rest of a
    request, a pipelined next one), filled without blocking by the watcher (``receive``),
    consumed by http.server in a worker (``readline(limit)``, ``read(n)``). ``state`` tells
    whether a whole request is in; it scans the head once, resuming where it stopped."""

    def __init__(self, sock: socket.socket):
        self.sock = sock
        self.buf = bytearray()
        self.deadline = float("inf")   # for a worker's read: the request's deadline
        self._rewind()

    def _rewind(self) -> None:
        self._pos = 0        # the scan of the head goes on from here
        self._lines = 0      # lines of the head scanned
        self._start = 0      # where the header lines start
        self._need = -1      # bytes of the whole request, once its head is scanned

    def receive(self) -> bool:
        """One recv without blocking (BlockingIOError when nothing came); False at the end of
        the stream."""
        data = self.sock.recv(65536)
        if not data:
            return False
        self.buf += data
        return True

    def state(self) -> int:
        """READY: a whole request is buffered (head and body), or as much of one as
        http.server reads before refusing it; TOO_LARGE: a head over MAX_HEAD; WAIT."""
        buf = self.buf
        while self._need < 0:
            p = self._pos
            j = buf.find(b"\n", p, p + MAX_LINE)
            if j < 0:
                if len(buf) - p > MAX_LINE:   # refused by readline(MAX_LINE + 1): 414 / 431
                    self._need = 0
                    break
                return TOO_LARGE if len(buf) > MAX_HEAD else WAIT
            self._pos = j + 1
            self._lines += 1
            if self._lines == 1:   # http.server reads headers after 3 words only (its split)
                self._start = j + 1
                if len(str(buf[:j + 1], "iso-8859-1").split()) != 3:
                    self._need = 0
            elif self._lines - 1 > MAX_HEADER_LINES:   # refused: "got more than 100 headers"
                self._need = 0
            elif j - p <= 1 and bytes(buf[p:j + 1]) in (b"\r\n", b"\n"):
                self._need = j + 1 + self._body(bytes(buf[self._start:j + 1]))
            if self._need < 0 and self._pos > MAX_HEAD:
                return TOO_LARGE
        return READY if len(buf) >= self._need else WAIT

    @staticmethod
    def _body(head: bytes) -> int:
        if b"content-length" not in head.lower():   # no header of that name: no body
            return 0
        try:   # the parser http.server uses, on the same bytes: the same headers
            headers = http.client.parse_headers(io.BytesIO(head))
        except Exception:  # noqa: BLE001 (whatever it is, the handler refuses it)
            return 0
        n, why = body_size(headers)
        return n if why is None else 0

    # -- http.server's side (a worker) --

    def _fill(self) -> bool:
        """More bytes for http.server, waiting at most until the deadline. The watcher hands
        over whole requests, so this waits only if its scan and the parser disagree."""
        left = self.deadline - time.monotonic()
        if left <= 0:
            raise TimeoutError("the request did not arrive in time")
        self.sock.settimeout(min(left, 3600.0))
        try:
            data = self.sock.recv(65536)
        finally:
            self.sock.settimeout(0.0)
        if not data:
            return False
        self.buf += data
        return True

    def readline(self, limit: int = -1) -> bytes:
        start = 0
        while True:
            i = self.buf.find(b"\n", start)
            if i >= 0 and (limit < 0 or i < limit):
                n = i + 1
                break
            if 0 <= limit <= len(self.buf):
                n = limit
                break
            start = len(self.buf)
            if not self._fill():
                n = len(self.buf)
                break
        return self._take(n)

    def read(self, n: int = -1) -> bytes:
        if n < 0:
            raise ValueError("read() needs a size here")
        while len(self.buf) < n and self._fill():
            pass
        return self._take(n)

    def _take(self, n: int) -> bytes:
        out = bytes(self.buf[:n])
        del self.buf[:n]
        self._rewind()   # the next scan starts at the new start of the buffer
        return out

    def pending(self) -> int:
        """Bytes received and not yet read (the start of a pipelined request)."""
        return len(self.buf)

    def close(self) -> None:
        pass


class WriteBudget:
    """A count within a limit, taken and given back from several threads: the bytes of answers
    queued and not yet sent over all connections, or the connections open."""

    def __init__(self, limit: int):
        self.limit = limit
        self.used = 0
        self._lock = threading.Lock()

    def take(self, n: int) -> bool:
        with self._lock:
            if self.used + n > self.limit:
                return False
            self.used += n
            return True

    def give(self, n: int) -> None:
        with self._lock:
            self.used -= n


class _Writer:
    """The write side: ``write`` sends what the socket takes at once and queues the rest (for
    the watcher's ``send_some``), or, over the budget, sends it blocking; the whole answer
    within ``timeout`` seconds of its first write (``start`` begins an answer)."""

    def __init__(self, sock: socket.socket, timeout: float, budget: WriteBudget):
        self.sock = sock
        self.timeout = timeout
        self.budget = budget
        self.out: collections.deque[memoryview] = collections.deque()
        self.queued = 0
        self.deadline = float("inf")
        self.broken = False   # a write failed or ran out of time: the stream is cut

    def start(self) -> None:
        self.deadline = float("inf")

    def write(self, data) -> int:
        view = memoryview(data if isinstance(data, bytes) else bytes(data))
        n = len(view)
        if self.deadline == float("inf"):
            self.deadline = time.monotonic() + self.timeout
        try:
            if not self.out:
                try:
                    view = view[self.sock.send(view):]
                except (BlockingIOError, InterruptedError):
                    pass
            if len(view):
                if self.budget.take(len(view)):
                    self.out.append(view)
                    self.queued += len(view)
                else:
                    self._send_blocking(view)
        except OSError:
            self.broken = True
            raise
        return n

    def _send_blocking(self, view: memoryview) -> None:
        pieces = [*self.out, view]
        self.discard()
        for piece in pieces:
            left = self.deadline - time.monotonic()
            if left <= 0:
                raise TimeoutError("the answer was not taken in time")
            self.sock.settimeout(left)   # sendall: the total time of the call
            try:
                self.sock.sendall(piece)
            finally:
                self.sock.settimeout(0.0)

    def send_some(self) -> bool:
        """Send what the socket takes (the watcher's); True once nothing is left."""
        while self.out:
            piece = self.out[0]
            k = self.sock.send(piece)
            self.queued -= k
            self.budget.give(k)
            if k < len(piece):
                self.out[0] = piece[k:]
                return False
            self.out.popleft()
        return True

    def discard(self) -> None:
        self.budget.give(self.queued)
        self.out.clear()
        self.queued = 0

    def flush(self) -> None:
        pass

    def close(self) -> None:
        pass


class Conn:
    """One client connection (its socket non-blocking): address, reader, writer, the deadline
    of what it is doing, and whether it closes once its answer is out."""

    __slots__ = ("sock", "addr", "rfile", "wfile", "deadline", "closing", "slot")

    def __init__(self, sock: socket.socket, addr, timeout: float, budget: WriteBudget,
                 slot: WriteBudget | None = None):
        try:  # the head and the body are separate writes: no Nagle wait for the ACK between
            sock.setsockopt(socket.IPPROTO_TCP, socket.TCP_NODELAY, 1)
        except OSError:
            pass
        sock.setblocking(False)
        self.sock = sock
        self.addr = addr
        self.rfile = _Reader(sock)
        self.wfile = _Writer(sock, timeout, budget)
        self.deadline = time.monotonic() + timeout   # the first request's: from the accept
        self.closing = False
        self.slot = slot  # the open connections' count this one holds a place in (given back
        #                   at the close)

    def close(self, abort: bool = False) -> None:
        """Close; ``abort``: at once, dropping what the kernel still holds to send (a reset,
        for an answer not taken in time: a plain close would still send it all)."""
        self.wfile.discard()
        slot, self.slot = self.slot, None
        if slot is not None:
            slot.give(1)
        try:
            if abort:
                self.sock.setsockopt(socket.SOL_SOCKET, socket.SO_LINGER, _RESET)
            else:
                self.sock.shutdown(socket.SHUT_RDWR)
        except OSError:
            pass
        self.sock.close()

    def refuse(self, answer: bytes) -> None:
        """Send a short answer without blocking (it fits in an empty socket buffer) and close;
        what the client already sent is read first, so that the close does not reset the
        connection before the answer is read."""
        try:
            for _ in range(16):
                if not self.sock.recv(65536):
                    break
        except OSError:
            pass
        try:
            self.sock.send(answer)
        except OSError:
            pass
        self.close()

    def refuse_busy(self) -> None:
        """503 (too many requests waiting) and close."""
        self.refuse(_BUSY)


def refuse_busy(sock: socket.socket) -> None:
    """503 (too many connections open) and close, for a connection that was accepted but is
    not served."""
    try:
        sock.setblocking(False)
        sock.send(_BUSY)
    except OSError:
        pass
    try:
        sock.shutdown(socket.SHUT_RDWR)
    except OSError:
        pass
    sock.close()


class Reactor(threading.Thread):
    """The watcher: holds the connections while they receive a request (handed to
    ``dispatch(conn)`` once whole) or send an answer, and closes those past their deadline.
    ``add(conn)`` (any thread) hands over a fresh connection, ``resume(conn)`` one a worker
    has served (to finish its answer, then wait for the next request)."""

    def __init__(self, dispatch, timeout: float):
        super().__init__(name="mlayer-view-watch", daemon=True)
        self._dispatch = dispatch
        self.timeout = timeout
        self._sel = selectors.DefaultSelector()
        self._wake_r, self._wake_w = socket.socketpair()
        self._wake_r.setblocking(False)
        self._wake_w.setblocking(False)
        self._sel.register(self._wake_r, selectors.EVENT_READ, None)
        self._incoming: collections.deque = collections.deque()
        self._watched: dict = {}
        self._stopping = False

    @property
    def n_idle(self) -> int:
        """Connections held by the watcher (receiving a request, or sending an answer)."""
        return len(self._watched)

    def add(self, conn: Conn) -> None:
        self._incoming.append(conn)
        self._wake()

    def resume(self, conn: Conn) -> None:
        conn.deadline = time.monotonic() + self.timeout   # the next request's, if no answer
        self.add(conn)                                     # waits (then: from its end)

    def _wake(self) -> None:
        try:
            self._wake_w.send(b"x")
        except OSError:  # full (a wake-up is pending anyway) or closed
            pass

    def stop(self) -> None:
        self._stopping = True
        self._wake()

    # -- the loop (the watcher's thread only) --

    def _watch(self, conn: Conn, events: int) -> None:
        if conn.sock in self._watched:
            self._sel.modify(conn.sock, events, conn)
        else:
            self._sel.register(conn.sock, events, conn)
            self._watched[conn.sock] = conn

    def _unwatch(self, conn: Conn) -> None:
        if self._watched.pop(conn.sock, None) is not None:
            self._sel.unregister(conn.sock)

    def _drop(self, conn: Conn, abort: bool = False) -> None:
        self._unwatch(conn)
        conn.close(abort)

    def _take(self, conn: Conn) -> None:
        """A connection handed over: its answer to finish, or its next request to await."""
        if conn.wfile.out:
            conn.deadline = conn.wfile.deadline
            self._watch(conn, selectors.EVENT_WRITE)
        elif conn.closing:
            conn.close()
        else:
            self._next_request(conn)

    def _next_request(self, conn: Conn) -> None:
        st = conn.rfile.state()
        if st == WAIT:
            self._watch(conn, selectors.EVENT_READ)
            return
        self._unwatch(conn)
        if st == READY:
            conn.rfile.deadline = conn.deadline
            self._dispatch(conn)
        else:
            conn.refuse(_TOO_LARGE)

    def _readable(self, conn: Conn) -> None:
        try:
            if not conn.rfile.receive():   # the client closed (mid-request, or between them)
                self._drop(conn)
                return
        except (BlockingIOError, InterruptedError):
            return
        except OSError:
            self._drop(conn)
            return
        if conn.rfile.state() != WAIT:
            self._next_request(conn)

    def _writable(self, conn: Conn) -> None:
        try:
            if not conn.wfile.send_some():
                return
        except (BlockingIOError, InterruptedError):
            return
        except OSError:
            self._drop(conn)
            return
        if conn.closing:
            self._drop(conn)
            return
        conn.deadline = time.monotonic() + self.timeout   # from the end of the answer
        self._next_request(conn)

    def run(self) -> None:
        tick = max(0.01, min(0.25, self.timeout / 8))
        next_sweep = 0.0
        try:
            while not self._stopping:
                while self._incoming:
                    conn = self._incoming.popleft()
                    try:
                        self._take(conn)
                    except (ValueError, OSError):  # closed meanwhile
                        self._drop(conn)
                for key, _ in self._sel.select(tick):
                    if key.data is None:
                        try:
                            while self._wake_r.recv(4096):
                                pass
                        except OSError:
                            pass
                        continue
                    conn = key.data
                    if conn.sock not in self._watched:   # dropped earlier in this round
                        continue
                    if conn.wfile.out:
                        self._writable(conn)
                    else:
                        self._readable(conn)
                now = time.monotonic()
                if now < next_sweep:   # deadlines are checked once a tick, not per event
                    continue
                next_sweep = now + tick
                for conn in [c for c in self._watched.values() if now > c.deadline]:
                    self._drop(conn, abort=bool(conn.wfile.out))   # (an answer not taken)
        finally:
            for conn in list(self._watched.values()) + list(self._incoming):
                conn.close()
            self._watched.clear()
            self._sel.close()
            self._wake_r.close()
            self._wake_w.close()


class Pool:
    """``threads`` worker threads (daemon, started at the first ``submit``) running
    ``work(item)`` for the queued items; ``submit`` returns False when ``max_pending`` items
    already wait."""

    def __init__(self, work, threads: int, max_pending: int):
        self._work = work
        self.threads = threads
        self._q: queue.Queue = queue.Queue(max_pending)
        self._workers: list[threading.Thread] = []
        self._lock = threading.Lock()

    @property
    def n_threads(self) -> int:
        return len(self._workers)

    def submit(self, item) -> bool:
        if not self._workers:
            with self._lock:
                while len(self._workers) < self.threads:
                    t = threading.Thread(target=self._loop, daemon=True,
                                         name=f"mlayer-view-worker-{len(self._workers)}")
                    self._workers.append(t)
                    t.start()
        try:
            self._q.put_nowait(item)
        except queue.Full:
            return False
        return True

    def _loop(self) -> None:
        while True:
            item = self._q.get()
            if item is None:
                return
            self._work(item)

    def stop(self) -> None:
        """Close what still waits and ask every worker to end after its current item."""
        while True:
            try:
                item = self._q.get_nowait()
            except queue.Empty:
                break
            if item is not None:
                item.close()
        for _ in self._workers:
            try:
                self._q.put_nowait(None)
            except queue.Full:
                break
