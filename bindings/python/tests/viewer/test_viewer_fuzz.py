"""A bounded-time fuzz target for the viewer's query handling (issue 19, item 6): thousands of
random and mutated query strings from a seeded RNG, first to parse_params alone, then through
the running server's API. The only answers allowed are 200 and 4xx with a JSON message that is
the viewer's own (no traceback, no internal status code of the C core); never a 500, never an
exception escaping into the server's log.

MLR_VIEWER_FUZZ_N (default 4000 HTTP requests, ten times as many parser calls) and
MLR_VIEWER_FUZZ_SECONDS
(default 60, the time bound of the HTTP part) make it longer, MLR_VIEWER_FUZZ_SEED changes the
seed."""
import http.client
import io
import json
import math
import os
import random
import sys
import threading
import time
from urllib.parse import quote

import pytest

import mlayer
from mlayer.viewer import make_server, parse_params
from mlayer.viewer.session import PARAMS, ParamError

N_HTTP = int(os.environ.get("MLR_VIEWER_FUZZ_N", "4000"))
SECONDS = float(os.environ.get("MLR_VIEWER_FUZZ_SECONDS", "60"))
SEED = int(os.environ.get("MLR_VIEWER_FUZZ_SEED", "19"))

KEYS = list(PARAMS)
ODD_KEYS = ["bogus", "", "ALPHA", "alpha ", "%61lpha", "clip[]", "token", "a" * 300, "fps%00",
            "\u00e9", "joint;clip"]
ODD_VALUES = ["", " ", "0", "1", "-1", "-0", "+3", " 2 ", "0.5", "4", "4.0000001", "1e308",
              "-1e308", "1e-320", "5e-324", "nan", "NaN", "-nan", "inf", "-inf", "Infinity",
              "1_0", "0x10", "0b1", "1e", ".", "-", "e5", "\uff11", "\u0663", "%00", "%ff%fe",
              "%", "%2", "%zz", "true", "false", "TRUE", "yes", "999999999", "9999999999",
              "000000001", "3.9999999999999996", "0.01", "0.0099", "36000", "36000.1", "1000",
              "1000.0000001", "0.099", "1.0e0", "1" * 400, "\u200b1", "1\u00a0", "%2B1"]
VALID = ["clip=0&alpha=1.5&arms=0.3&legs=2&spine=1&denoise=0&contacts=1&length=8&fps=60"
         "&warp=2&joint=3", "clip=0", "clip=0&fps=24&length=3.5", "clip=0&alpha=0&warp=5",
         "clip=1", "clip=0&length=0.8&fps=1000", "clip=0&joint=26&contacts=0"]
PATHS = ["/api/process", "/api/process", "/api/process", "/api/download", "/api/clip",
         "/api/clips"]


def _value(rng: random.Random, key: str) -> str:
    r = rng.random()
    if r < 0.35 and key in PARAMS:
        kind, lo, hi, _ = PARAMS[key]
        if kind == "bool":
            return rng.choice(["0", "1", "true", "false"])
        lo = 0.0 if lo is None else lo
        hi = 40.0 if hi is None else hi
        v = rng.uniform(lo - 0.1 * (hi - lo), hi + 0.1 * (hi - lo))
        return str(int(v)) if kind == "int" else rng.choice([repr(v), f"{v:.3f}", f"{v:g}"])
    if r < 0.75:
        return rng.choice(ODD_VALUES)
    n = rng.randint(0, 12)
    return "".join(rng.choice("0123456789.eE+-_ %&=;#?/\\\"'<>abcnaif\u00e9\x00\x7f")
                   for _ in range(n))


def _query(rng: random.Random) -> str:
    if rng.random() < 0.3:  # a valid query, mutated at the character level
        q = list(rng.choice(VALID))
        for _ in range(rng.randint(0, 4)):
            op, i = rng.random(), rng.randrange(len(q) + 1)
            if op < 0.4:
                q.insert(i, rng.choice("0123456789.&=-e%;x"))
            elif op < 0.7 and i < len(q):
                del q[i]
            elif i < len(q):
                q[i] = rng.choice("0123456789.&=-e%")
        return "".join(q)
    pairs = []
    for _ in range(rng.randint(0, 9)):
        key = rng.choice(KEYS) if rng.random() < 0.85 else rng.choice(ODD_KEYS)
        form = rng.random()
        if form < 0.9:
            pairs.append(f"{key}={_value(rng, key)}")
        elif form < 0.95:
            pairs.append(key)
        else:
            pairs.append(f"={_value(rng, key)}")
    if pairs and rng.random() < 0.7 and not any(p.startswith("clip=") for p in pairs):
        pairs.insert(0, f"clip={rng.choice(['0', '0', '1', '2', '7'])}")
    sep = rng.choice(["&"] * 8 + [";", "&&"])
    return sep.join(pairs)


def _check_value(key, v):
    kind, lo, hi, default = PARAMS[key]
    if v is None:
        assert default is None
        return
    if kind == "bool":
        assert v is True or v is False
    elif kind == "int":
        assert isinstance(v, int) and 0 <= v < 10**9
    elif kind == "keys":  # the canonical text of valid keys
        c = mlayer.AlphaCurve.parse(v)
        assert str(c) == v and lo <= c.values.min() and c.values.max() <= hi
    else:
        assert isinstance(v, float) and math.isfinite(v) and lo <= v <= hi


def test_parse_params_fuzz():
    rng = random.Random(SEED)
    keys = tuple(PARAMS)
    ok = bad = 0
    for _ in range(N_HTTP * 10):
        q = _query(rng)
        try:
            p = parse_params(q, keys)
        except ParamError as e:
            assert e.status == 400 and str(e), q
            assert len(str(e)) < 2000, q
            bad += 1
            continue
        assert set(p) == set(keys), q
        for k, v in p.items():
            _check_value(k, v)
        ok += 1
    assert ok > 1000 and bad > 1000, (ok, bad)  # both sides were exercised


@pytest.fixture(scope="module")
def fuzz_server(mocap, tmp_path_factory):
    broken = tmp_path_factory.mktemp("fuzz") / "broken.bvh"
    broken.write_text("HIERARCHY\nROOT Hips\n{\n")
    log = io.StringIO()
    # a small clip and a modest cap keep each computed answer cheap
    srv = make_server([mocap / "bandai1_walk_happy_001.bvh", broken], log=log,
                      max_values=200_000, cache_bytes=32 << 20)
    t = threading.Thread(target=srv.serve_forever, kwargs={"poll_interval": 0.05}, daemon=True)
    t.start()
    yield srv, log
    srv.shutdown()
    srv.server_close()
    t.join(5)


def test_api_fuzz(fuzz_server):
    srv, log = fuzz_server
    rng = random.Random(SEED + 1)
    port = srv.server_address[1]
    c = http.client.HTTPConnection("127.0.0.1", port, timeout=60)
    seen: dict = {}
    t0 = time.monotonic()
    n = 0
    while n < N_HTTP and time.monotonic() - t0 < SECONDS:
        path = rng.choice(PATHS)
        q = _query(rng)
        # what a client can put on the request line: the rest percent-encoded
        target = path + "?" + quote(q, safe="&=;%+,/:@!$'()*-._~") if q or rng.random() < 0.5 \
            else path
        try:
            c.request("GET", target, headers={"X-Mlayer-Token": srv.token})
            r = c.getresponse()
            body = r.read()
        except (http.client.HTTPException, OSError) as e:
            pytest.fail(f"{target}: {type(e).__name__}: {e}")
        n += 1
        seen[r.status] = seen.get(r.status, 0) + 1
        assert r.status == 200 or 400 <= r.status < 500, (target, r.status, body[:300])
        if r.status != 200 or r.getheader("Content-Type") == "application/json":
            assert r.getheader("Content-Type") == "application/json", target
            d = json.loads(body)
        if r.status != 200:
            msg = d["error"]
            assert isinstance(msg, str) and msg, target
            for internal in ("Traceback", "MLR_E_", "allow_extreme", "Error:"):
                assert internal not in msg, (target, msg)
        if r.getheader("Connection") == "close":
            c.close()
    c.close()
    assert "Traceback" not in log.getvalue(), log.getvalue()[-2000:]
    assert n >= min(N_HTTP, 300), n          # the time bound left a real run
    assert seen.get(200, 0) > 20 and seen.get(400, 0) > 20, seen
    print(f"viewer API fuzz: {n} requests in {time.monotonic() - t0:.1f} s: {seen}",
          file=sys.stderr)
