"""Latency of `mlayer view` under concurrent loopback clients, on cached requests (issue 19):
p50 and p99 per request for 50, 100 and 200 clients that start together.

The server runs as `python -m mlayer view CLIP` in its own process (its default limits: 8
worker threads, backlog 1024); the script reads the session token from the page as a browser
would, computes the request once (so every measured request is a cache hit) and then, per
client count and round, starts that many client threads at once, each sending --requests
requests of /api/process (the same slider position), either each on a new connection
(--mode fresh: connect, request, close; the harder case for the accept queue) or all on one
kept-alive connection (--mode keepalive). A request's latency runs from before its connect (or
its send) to the last byte of the answer. Every answer must be 200 and cached. Figures are
medians over --rounds rounds (the machine is shared).

    python bench/python/bench_viewer_load.py [--clip cmu_131_01_mj_style_walk.bvh]
        [--clients 50,100,200] [--requests 5] [--rounds 3] [--mode fresh|keepalive|both]
        [--mocap DIR]
"""
from __future__ import annotations

import argparse
import http.client
import json
import re
import statistics
import subprocess
import sys
import threading
import time

import numpy as np

from benchutil import mocap_dir

QUERY = "clip=0&alpha=1.7&legs=0.8&denoise=1&contacts=1&joint=3"


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


def one_round(host, port, token, clients: int, requests: int, mode: str):
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
                    conn = http.client.HTTPConnection(host, port, timeout=300)
                conn.request("GET", path, headers=headers)
                r = conn.getresponse()
                body = r.read()
                mine.append(time.perf_counter() - t0)
                if r.status != 200 or b'"cached":true' not in body[:40] + body[-40:]:
                    bad.append(f"{r.status} {body[:80]!r}")
            except (OSError, http.client.HTTPException) as e:
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
        print(f"{'mode':<10} {'clients':>7} {'p50 ms':>9} {'p99 ms':>9} {'max ms':>9} "
              f"{'req/s':>7} failures")
        for mode in modes:
            for n in counts:
                p50s, p99s, maxs, rates, nfail = [], [], [], [], 0
                for _ in range(a.rounds):
                    t0 = time.perf_counter()
                    lat, fails = one_round(host, port, token, n, a.requests, mode)
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
    finally:
        proc.terminate()
        proc.wait(10)
    return 0


if __name__ == "__main__":
    sys.exit(main())
