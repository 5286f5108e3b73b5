"""The viewer's connection handling (stdlib only): a bounded pool of worker threads instead of a
thread per connection, a watcher thread that holds the idle keep-alive connections (a
connection takes a worker only while one of its requests is read, computed and written), and
socket reading and writing with deadlines.

- A connection that sends nothing for ``timeout`` seconds (a fresh one or a kept-alive one
  between requests) is closed by the watcher.
- A request must arrive whole (request line, headers and body) within ``timeout`` seconds of
  its first byte: every read is given only the time left, so a client that trickles one byte
  at a time is cut off at the deadline, not at each byte.
- A response is written in pieces of 1 MiB, each within ``timeout`` seconds.
- At most ``threads`` requests are served at a time (``threads`` worker threads, whatever
  the number of connections); up to ``max_pending`` more connections with a request waiting
  are queued; beyond that a connection is answered 503 and closed.
"""
from __future__ import annotations

import collections
import queue
import selectors
import socket
import threading
import time

__all__ = ["Conn", "Reactor", "Pool"]

_CHUNK = 1 << 20

_BUSY = (b"HTTP/1.1 503 Service Unavailable\r\nContent-Type: application/json\r\n"
         b"Connection: close\r\nContent-Length: %d\r\n\r\n%s")
_BUSY_BODY = (b'{"error":"the viewer is busy: too many connections are waiting; retry, or start '
              b'mlayer view with more --threads"}')


class _Reader:
    """The read side of a connection as http.server expects it (``readline(limit)``,
    ``read(n)``), over the raw socket, with a deadline on the whole request and the bytes
    already received but not yet consumed (a pipelined next request) kept for the next one."""

    def __init__(self, sock: socket.socket):
        self.sock = sock
        self.buf = bytearray()
        self.deadline = float("inf")

    def _fill(self) -> bool:
        left = self.deadline - time.monotonic()
        if left <= 0:
            raise TimeoutError("the request did not arrive in time")
        self.sock.settimeout(min(left, 3600.0))
        data = self.sock.recv(65536)
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
        out = bytes(self.buf[:n])
        del self.buf[:n]
        return out

    def read(self, n: int = -1) -> bytes:
        if n < 0:
            raise ValueError("read() needs a size here")
        while len(self.buf) < n and self._fill():
            pass
        out = bytes(self.buf[:n])
        del self.buf[:n]
        return out

    def pending(self) -> int:
        """Bytes received and not yet read (the start of a pipelined request)."""
        return len(self.buf)

    def close(self) -> None:
        pass


class _Writer:
    """The write side: ``write`` sends in pieces of 1 MiB, each within ``timeout`` seconds."""

    def __init__(self, sock: socket.socket, timeout: float):
        self.sock = sock
        self.timeout = timeout

    def write(self, data) -> int:
        view = memoryview(data)
        self.sock.settimeout(self.timeout)
        for k in range(0, len(view), _CHUNK):
            self.sock.sendall(view[k:k + _CHUNK])
        return len(view)

    def flush(self) -> None:
        pass

    def close(self) -> None:
        pass


class Conn:
    """One client connection: its socket, address, reader and writer."""

    __slots__ = ("sock", "addr", "rfile", "wfile", "since")

    def __init__(self, sock: socket.socket, addr, timeout: float):
        try:  # the head and the body are separate writes: no Nagle wait for the ACK between
            sock.setsockopt(socket.IPPROTO_TCP, socket.TCP_NODELAY, 1)
        except OSError:
            pass
        self.sock = sock
        self.addr = addr
        self.rfile = _Reader(sock)
        self.wfile = _Writer(sock, timeout)
        self.since = time.monotonic()

    def close(self) -> None:
        try:
            self.sock.shutdown(socket.SHUT_RDWR)
        except OSError:
            pass
        self.sock.close()

    def refuse_busy(self) -> None:
        """Answer 503 without blocking (the bytes fit in an empty socket buffer) and close."""
        try:
            self.sock.setblocking(False)
            self.sock.send(_BUSY % (len(_BUSY_BODY), _BUSY_BODY))
        except OSError:
            pass
        self.close()


class Reactor(threading.Thread):
    """Watches the idle connections: a readable one goes to ``dispatch(conn)``, one idle for
    ``timeout`` seconds is closed. ``add(conn)`` (any thread) hands a connection over."""

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
        return len(self._watched)

    def add(self, conn: Conn) -> None:
        conn.since = time.monotonic()
        self._incoming.append(conn)
        self._wake()

    def _wake(self) -> None:
        try:
            self._wake_w.send(b"x")
        except OSError:  # full (a wake-up is pending anyway) or closed
            pass

    def stop(self) -> None:
        self._stopping = True
        self._wake()

    def run(self) -> None:
        tick = max(0.01, min(0.25, self.timeout / 4))
        try:
            while not self._stopping:
                while self._incoming:
                    conn = self._incoming.popleft()
                    try:
                        self._sel.register(conn.sock, selectors.EVENT_READ, conn)
                    except (ValueError, OSError):  # closed meanwhile
                        conn.close()
                        continue
                    self._watched[conn.sock] = conn
                for key, _ in self._sel.select(tick):
                    if key.data is None:
                        try:
                            while self._wake_r.recv(4096):
                                pass
                        except OSError:
                            pass
                        continue
                    conn = key.data
                    self._sel.unregister(conn.sock)
                    del self._watched[conn.sock]
                    self._dispatch(conn)
                now = time.monotonic()
                for sock, conn in list(self._watched.items()):
                    if now - conn.since > self.timeout:
                        self._sel.unregister(sock)
                        del self._watched[sock]
                        conn.close()
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
