"""Latency of `mlayer view` under concurrent loopback clients, on cached requests (issue 19):
p50 and p99 per request for 50, 100 and 200 clients that start together.

The server runs as `python -m mlayer view CLIP` in its own process (its default limits: 8
worker threads, backlog 1024); the script reads the session token from the page as a browser
would, computes the request once (so every measured request is a cache hit) and then, per
client count and round, starts that many client threads at once, each sending --requests
requests of /api/process (the same slider position), either each on a new connection
(--mode fresh: connect, request, close; the harder case for the accept queue) or all on one
kept-alive connection (--mode keepalive). A request's latency runs from before its connect (or
its send) to the last byte of the answer. Every answer must be 200 and cached; a request that
fails (an error, or no answer within --client-timeout seconds) counts as a failure and with the
time it took to fail. Figures are medians over --rounds rounds (the machine is shared).

Under attack (issue 39): --slowloris N keeps N connections open during the rounds, each
sending a request head one byte every --slow-every seconds and never finishing it (reopened
when the server drops one, as a slowloris client does); --noread N keeps N clients asking for
a 6.9 MB answer (the walk at 500 fps over 20 s) that they never read (reopened likewise, with a
64 KiB receive buffer, renewed after 12 s if the server has not reset them). The line after
the table says how often the server dropped them.

    python bench/python/bench_viewer_load.py [--clip cmu_131_01_mj_style_walk.bvh]
        [--clients 50,100,200] [--requests 5] [--rounds 3] [--mode fresh|keepalive|both]
        [--slowloris 200] [--slow-every 1] [--noread 16] [--client-timeout 60]
        [--mocap DIR]
"""
from __future__ import annotations

import argparse
import http.client
import json
import re
import socket
import statistics
import subprocess
import sys
import threading
import time

import numpy as np

from benchutil import mocap_dir

QUERY = "clip=0&alpha=1.7&legs=0.8&denoise=1&contacts=1&joint=3"
BIG_QUERY = "clip=0&length=20&fps=500"   # 6.9 MB on the walk


class Attack(threading.Thread):
    """``n`` connections kept open against the server, each sending ``first`` at its connect
    and then ``step`` one byte every ``every`` seconds (``step`` empty: nothing more, the
    client never reads); one the server closes is reopened and counted in ``dropped``, one
    older than ``hold`` seconds is reopened too (a server may close without the client seeing
    it: a FIN behind unread data)."""

    def __init__(self, host, port, n: int, first: bytes, step: bytes, every: float,
                 rcvbuf: int = 0, hold: float = float("inf")):
        super().__init__(daemon=True)
        self.addr, self.n, self.first, self.step, self.every = (host, port), n, first, step, every
        self.rcvbuf, self.hold = rcvbuf, hold
        self.socks: list[socket.socket | None] = [None] * n
        self.since = [0.0] * n
        self.dropped = self.failed = self.renewed = 0
        self.stop = threading.Event()

    def _open(self) -> socket.socket | None:
        try:
            s = socket.socket(socket.AF_INET, socket.SOCK_STREAM)
            if self.rcvbuf:
                s.setsockopt(socket.SOL_SOCKET, socket.SO_RCVBUF, self.rcvbuf)
            s.settimeout(10)
            s.connect(self.addr)
            s.sendall(self.first)
            s.setblocking(False)
            return s
        except OSError:
            self.failed += 1
            return None

    def start_all(self) -> None:
        for i in range(self.n):
            self.socks[i] = self._open()
            self.since[i] = time.monotonic()
        self.start()

    def run(self) -> None:
        k = 0
        while not self.stop.wait(self.every):
            for i, s in enumerate(self.socks):
                gone = s is None
                if s is not None:
                    try:
                        if self.step:
                            s.send(self.step[k % len(self.step):][:1])
                            gone = s.recv(65536) == b""
                        else:   # reset (the state no longer ESTABLISHED), without reading
                            gone = s.getsockopt(socket.IPPROTO_TCP, socket.TCP_INFO, 8)[0] != 1
                    except BlockingIOError:
                        pass
                    except OSError:
                        gone = True
                old = not gone and time.monotonic() - self.since[i] > self.hold
                if gone or old:
                    if s is not None:
                        s.close()
                        self.dropped += gone
                        self.renewed += old
                    self.socks[i] = self._open()
                    self.since[i] = time.monotonic()
            k += 1

    def close(self) -> None:
        self.stop.set()
        self.join(30)
        for s in self.socks:
            if s is not None:
                s.close()


def start_server(clip: str):
    p = subprocess.Popen([sys.executable, "-m", "mlayer", "view", clip], stdout=subprocess.PIPE,
                         stderr=subprocess.PIPE, text=True)
    line = p.stdout.readline()
    m = re.search(r"at http://([\d.]+):(\d+)/", line)
    if not m:
        p.kill()
        raise SystemExit(f"bench: the server did not start: {line!r} {p.stderr.read()[:500]}")
    return p, m.group(1), int(m.group(2))


def token_of(host, port) -> str:
    c = http.client.HTTPConnection(host, port, timeout=60)
    c.request("GET", "/")
    html = c.getresponse().read().decode()
    c.close()
    m = re.search(r'<meta name="mlayer-token" content="([^"]+)">', html)
    return m.group(1) if m else ""   # a viewer from before the token (for a comparison)


def one_round(host, port, token, clients: int, requests: int, mode: str,
              client_timeout: float = 300.0):
    """Latencies (s) of every request of every client, and the failures."""
    lat: list[float] = []
    fails: list[str] = []
    lock = threading.Lock()
    go = threading.Barrier(clients + 1)
    headers = {"X-Mlayer-Token": token}
    path = f"/api/process?{QUERY}"

    def client():
        mine, bad = [], []
        conn = None
        go.wait()
        for _ in range(requests):
            t0 = time.perf_counter()
            try:
                if conn is None:
                    conn = http.client.HTTPConnection(host, port, timeout=client_timeout)
                conn.request("GET", path, headers=headers)
                r = conn.getresponse()
                body = r.read()
                mine.append(time.perf_counter() - t0)
                if r.status != 200 or b'"cached":true' not in body[:40] + body[-40:]:
                    bad.append(f"{r.status} {body[:80]!r}")
            except (OSError, http.client.HTTPException) as e:
                mine.append(time.perf_counter() - t0)
                bad.append(f"{type(e).__name__}: {e}")
                conn = None
                continue
            if mode == "fresh":
                conn.close()
                conn = None
        if conn is not None:
            conn.close()
        with lock:
            lat.extend(mine)
            fails.extend(bad)

    ts = [threading.Thread(target=client, daemon=True) for _ in range(clients)]
    for t in ts:
        t.start()
    go.wait()
    for t in ts:
        t.join()
    return lat, fails


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--clip", default="cmu_131_01_mj_style_walk.bvh")
    ap.add_argument("--clients", default="50,100,200")
    ap.add_argument("--requests", type=int, default=5)
    ap.add_argument("--rounds", type=int, default=3)
    ap.add_argument("--mode", choices=("fresh", "keepalive", "both"), default="both")
    ap.add_argument("--slowloris", type=int, default=0, metavar="N")
    ap.add_argument("--slow-every", type=float, default=1.0, metavar="SECONDS")
    ap.add_argument("--noread", type=int, default=0, metavar="N")
    ap.add_argument("--client-timeout", type=float, default=300.0, metavar="SECONDS")
    ap.add_argument("--mocap", default=str(mocap_dir()))
    a = ap.parse_args()
    counts = [int(x) for x in a.clients.split(",")]
    modes = ("fresh", "keepalive") if a.mode == "both" else (a.mode,)
    proc, host, port = start_server(f"{a.mocap}/{a.clip}")
    try:
        token = token_of(host, port)
        c = http.client.HTTPConnection(host, port, timeout=300)
        c.request("GET", f"/api/process?{QUERY}", headers={"X-Mlayer-Token": token})
        r = c.getresponse()
        body = r.read()
        c.close()
        if r.status != 200:
            raise SystemExit(f"bench: {r.status} {body[:300]!r}")
        d = json.loads(body)
        print(f"clip {a.clip}: {d['frames']} frames, answer {len(body) / 1e3:.0f} kB; "
              f"{a.requests} requests per client, median of {a.rounds} rounds")
        attacks = []
        if a.noread:
            c = http.client.HTTPConnection(host, port, timeout=300)   # computed once: cached
            c.request("GET", f"/api/process?{BIG_QUERY}", headers={"X-Mlayer-Token": token})
            big = len(c.getresponse().read())
            c.close()
            attacks.append(Attack(host, port, a.noread, (
                f"GET /api/process?{BIG_QUERY} HTTP/1.1\r\nHost: {host}:{port}\r\n"
                f"X-Mlayer-Token: {token}\r\n\r\n").encode(), b"", 0.5, rcvbuf=65536,
                hold=12.0))
            print(f"{a.noread} clients that never read a {big / 1e6:.1f} MB answer")
        if a.slowloris:
            attacks.append(Attack(host, port, a.slowloris, (
                f"GET /api/clips HTTP/1.1\r\nHost: {host}:{port}\r\nX-Padding: ").encode(),
                b"a", a.slow_every))
            print(f"{a.slowloris} slowloris connections (a byte every {a.slow_every:g} s)")
        for at in attacks:
            at.start_all()
        if attacks:
            time.sleep(2.0)   # every attacker has sent its first bytes
        print(f"{'mode':<10} {'clients':>7} {'p50 ms':>9} {'p99 ms':>9} {'max ms':>9} "
              f"{'req/s':>7} failures")
        for mode in modes:
            for n in counts:
                p50s, p99s, maxs, rates, nfail = [], [], [], [], 0
                for _ in range(a.rounds):
                    t0 = time.perf_counter()
                    lat, fails = one_round(host, port, token, n, a.requests, mode,
                                           a.client_timeout)
                    wall = time.perf_counter() - t0
                    nfail += len(fails)
                    if fails:
                        print(f"  {mode} {n}: {len(fails)} failures, e.g. {fails[0]}")
                    x = np.asarray(lat) * 1e3
                    p50s.append(np.percentile(x, 50))
                    p99s.append(np.percentile(x, 99))
                    maxs.append(x.max())
                    rates.append(len(lat) / wall)
                print(f"{mode:<10} {n:>7} {statistics.median(p50s):>9.1f} "
                      f"{statistics.median(p99s):>9.1f} {statistics.median(maxs):>9.1f} "
                      f"{statistics.median(rates):>7.0f} {nfail}", flush=True)
        for at in attacks:
            at.close()
            print(f"attack of {at.n}: the server dropped {at.dropped} connection(s), "
                  f"{at.renewed} renewed after {at.hold:g} s, {at.failed} connect(s) failed")
    finally:
        proc.terminate()
        proc.wait(10)
    return 0


if __name__ == "__main__":
    sys.exit(main())
