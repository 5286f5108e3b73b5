"""mlayer view without a browser: body parts, parameter validation, the HTTP API (status codes,
path traversal, Host check), the processing pipeline against mlayer's own functions, the CLI.
The browser tests are in test_viewer_browser.py."""
import http.client
import json
import subprocess
import sys
import threading
import time
import urllib.parse

import numpy as np
import pytest

import mlayer
from conftest import requires
from mlayer import quat
from mlayer.guards.contacts import detect_contacts
from mlayer.guards.metrics import body_height, foot_sliding
from mlayer.viewer import body_parts, is_loopback, make_server, parse_params
from mlayer.viewer.session import PARAMS, ParamError

WALK = "cmu_131_01_mj_style_walk.bvh"


@pytest.fixture(scope="module")
def bad_clip(tmp_path_factory):
    p = tmp_path_factory.mktemp("bad") / "broken.bvh"
    p.write_text("HIERARCHY\nROOT Hips\n{\n  OFFSET 0 0 0\n  CHANNELS 3 Xposition\n")
    return p


@pytest.fixture(scope="module")
def server(mocap, bad_clip):
    srv = make_server([mocap / WALK, bad_clip, mocap / "bandai1_walk_happy_001.bvh"],
                      log=sys.stderr)
    t = threading.Thread(target=srv.serve_forever, kwargs={"poll_interval": 0.05}, daemon=True)
    t.start()
    yield srv
    srv.shutdown()
    srv.server_close()
    t.join(5)


def get(srv, path, host=None, headers=None, token=True):
    """(status, headers, body bytes) of GET path, sent as is (no normalization), with the
    session token the page carries (unless ``token`` is False)."""
    c = http.client.HTTPConnection("127.0.0.1", srv.server_address[1], timeout=30)
    try:
        c.putrequest("GET", path, skip_host=True)
        c.putheader("Host", host or f"127.0.0.1:{srv.server_address[1]}")
        if token:
            c.putheader("X-Mlayer-Token", srv.token)
        for k, v in (headers or {}).items():
            c.putheader(k, v)
        c.endheaders()
        r = c.getresponse()
        return r.status, dict(r.getheaders()), r.read()
    finally:
        c.close()


def get_json(srv, path, expect=200):
    status, headers, body = get(srv, path)
    assert status == expect, body[:300]
    assert headers["Content-Type"] == "application/json"
    return json.loads(body)


def f32(b64, shape):
    import base64
    return np.frombuffer(base64.b64decode(b64), dtype=np.float32).reshape(shape)


# ---- body parts -------------------------------------------------------------------------------

@pytest.mark.parametrize("clip, arms, legs", [
    (WALK, {"LeftShoulder", "RightWrist", "LThumb"}, {"LHipJoint", "LeftKnee", "RightToe"}),
    ("cmu_10_01_soccer_kick.bvh", {"lCollar", "rShldr", "lPinky2"},
     {"rButtock", "lThigh", "rFoot"}),
    ("bandai1_walk_happy_001.bvh", {"Shoulder_L", "Hand_R"}, {"UpperLeg_L", "Toes_R"}),
    ("cmu_02_03_run_jog_25fps.bvh", {"rcollar", "lelbow", "finger2-1.r"},
     {"lbuttock", "rhip", "toe1-1.l"}),
    ("ai4a_dog_D1_008_KAN01_002.bvh", {"LeftArm", "RightHand"}, {"LeftUpLeg", "RightFoot"}),
])
def test_body_parts_from_names(mocap, clip, arms, legs):
    m = mlayer.read_bvh(mocap / clip)
    parts = dict(zip(m.joint_names, body_parts(m.joint_names, m.parents)))
    assert {n for n in arms if parts[n] != "arms"} == set()
    assert {n for n in legs if parts[n] != "legs"} == set()
    root = m.joint_names[0]
    assert parts[root] == "spine"
    for n in m.joint_names:  # head and neck are never limbs
        if n.lower() in ("head", "neck", "spine", "chest", "tail"):
            assert parts[n] == "spine", n


def test_body_parts_every_clip_has_all_three(mocap):
    for f in sorted(mocap.glob("*.bvh")):
        m = mlayer.read_bvh(f)
        assert set(body_parts(m.joint_names, m.parents)) == {"arms", "legs", "spine"}, f.name


# ---- parameters -------------------------------------------------------------------------------

def test_parse_params_defaults_and_values():
    keys = tuple(PARAMS)
    p = parse_params("", keys)
    assert p["alpha"] == 1.0 and p["denoise"] is True and p["arms"] is None and p["clip"] is None
    p = parse_params("clip=2&alpha=2.5&arms=0&denoise=false&contacts=1&fps=60&warp=1.5", keys)
    assert (p["clip"], p["alpha"], p["arms"], p["denoise"], p["contacts"], p["fps"],
            p["warp"]) == (2, 2.5, 0.0, False, True, 60.0, 1.5)
    assert p["keys"] is None and parse_params("keys=", keys)["keys"] is None
    assert parse_params("keys=0%3A1%2C%202.5%3A3", keys)["keys"] == "0:1,2.5:3"


@pytest.mark.parametrize("query, words", [
    ("alpha=nan", "finite"), ("alpha=inf", "finite"), ("alpha=-1", "[0, 4]"),
    ("alpha=4.5", "[0, 4]"), ("alpha=abc", "number"), ("alpha=", "number"),
    ("fps=0", "[1, 1000]"), ("warp=6", "[0, 5]"), ("denoise=2", "0, 1"),
    ("clip=-1", "non-negative integer"), ("clip=1.5", "non-negative integer"),
    ("clip=..%2F..%2Fetc%2Fpasswd", "non-negative integer"), ("clip=%2Fetc%2Fpasswd", "integer"),
    ("path=/etc/passwd", "unknown parameter 'path'"), ("alpha=1&alpha=2", "twice"),
    ("alpha", "malformed"),
    ("keys=0:1,2", "keys: alpha keys: key 1 '2' is not TIME:ALPHA"),
    ("keys=0:1,0:2", "times must increase"), ("keys=0:1,1:5", "alpha of key 1 must be in [0, 4]"),
    ("keys=-1:1", "time of key 0 must be in [0, 36000]"), ("keys=0:nan", "alpha of key 0"),
    ("keys=" + ",".join(f"{k}:1" for k in range(65)), "at most 64 keys"),
])
def test_parse_params_rejects(query, words):
    with pytest.raises(ParamError) as e:
        parse_params(query, tuple(PARAMS))
    assert e.value.status == 400
    assert words in str(e.value)


def test_is_loopback():
    assert is_loopback("127.0.0.1") and is_loopback("localhost") and is_loopback("::1")
    assert is_loopback("127.0.0.2") and is_loopback("[::1]")
    assert not is_loopback("0.0.0.0") and not is_loopback("192.168.1.10")
    assert not is_loopback("example.com") and not is_loopback("::")


# ---- HTTP API ---------------------------------------------------------------------------------

def test_clips_lists_errors(server, bad_clip):
    d = get_json(server, "/api/clips")["clips"]
    assert [c["name"] for c in d] == [WALK, "broken.bvh", "bandai1_walk_happy_001.bvh"]
    assert d[0]["error"] is None and d[0]["frames"] == 994
    assert str(bad_clip) in d[1]["error"] and ":6:" in d[1]["error"]
    assert "frames" not in d[1]


def test_page_and_static_files(server):
    for path, ctype, word in (("/", "text/html", b"mlayer view"),
                              ("/viewer.js", "text/javascript", b"mlayerViewer"),
                              ("/viewer.css", "text/css", b"canvas")):
        status, headers, body = get(server, path)
        assert status == 200 and headers["Content-Type"].startswith(ctype) and word in body
        assert "script-src 'self'" in headers["Content-Security-Policy"]
        assert headers["X-Content-Type-Options"] == "nosniff"
    # the page loads nothing from elsewhere (works offline)
    for path in ("/", "/viewer.js", "/viewer.css"):
        body = get(server, path)[2].decode()
        assert "http://" not in body and "https://" not in body, path


@pytest.mark.parametrize("path", [
    "/../../../../etc/passwd", "/static/../viewer.js", "/%2e%2e/%2e%2e/etc/passwd",
    "/viewer.js/../../etc/passwd", "/api/clip/../clips", "/..%2f..%2fetc%2fpasswd",
    "/etc/passwd", "/mlayer/viewer/server.py", "/server.py", "/__init__.py", "//etc/passwd",
    "/api/clips/", "/index.html/",
])
def test_path_traversal_fails(server, path):
    status, _, body = get(server, path)
    assert status == 404, (path, body[:200])
    assert b"root:" not in body and b"import" not in body


def test_clip_paths_are_not_accepted(server):
    for q in ("clip=" + urllib.parse.quote(str(server.clips[0].path)), "clip=0&file=/etc/passwd",
              "clip=../0"):
        d = get_json(server, f"/api/process?{q}", 400)
        assert "error" in d


def test_unknown_clip_and_bad_parameters(server):
    assert "no clip 3" in get_json(server, "/api/clip?clip=3", 404)["error"]
    assert "no clip 99" in get_json(server, "/api/process?clip=99", 404)["error"]
    assert "failed to load" in get_json(server, "/api/process?clip=1", 409)["error"]
    assert "missing parameter 'clip'" in get_json(server, "/api/process", 400)["error"]
    assert "unknown parameter 'bogus'" in get_json(server, "/api/process?clip=0&bogus=1",
                                                   400)["error"]
    assert "finite" in get_json(server, "/api/process?clip=0&alpha=NaN", 400)["error"]
    assert "in [0, 4]" in get_json(server, "/api/process?clip=0&legs=-0.5", 400)["error"]
    assert "within 0.1x" in get_json(server, "/api/process?clip=0&length=500", 400)["error"]
    msg = get_json(server, "/api/process?clip=0&keys=0:1,1:1,0.5:2", 400)["error"]
    assert "keys: alpha keys: times must increase: key 2" in msg and "MLR_E_" not in msg
    assert "joint must be below 31" in get_json(server, "/api/process?clip=0&joint=31",
                                                400)["error"]
    assert "takes no parameters" in get_json(server, "/viewer.js?x=1", 400)["error"]
    assert "unknown parameter" in get_json(server, "/api/clips?clip=0", 400)["error"]


def test_host_header_checked_on_loopback(server):
    status, _, body = get(server, "/api/clips", host="attacker.example:80")
    assert status == 403 and b"Host" in body
    port = server.server_address[1]
    assert get(server, "/api/clips", host=f"localhost:{port}")[0] == 200


def test_original_payload(server, mocap):
    d = get_json(server, "/api/clip?clip=0")
    m = mlayer.read_bvh(mocap / WALK)
    J, E = m.n_joints, m.skeleton.n_end_sites
    assert d["frames"] == m.n_frames and d["n_points"] == J + E
    pts = f32(d["positions"], (m.n_frames, J + E, 3))
    np.testing.assert_allclose(pts[:, :J], m.positions(), rtol=1e-6, atol=1e-4)
    np.testing.assert_allclose(pts[:, J:], m.end_site_positions(), rtol=1e-6, atol=1e-4)
    assert d["parents"][:J] == list(m.parents)
    names, c = detect_contacts(m)
    assert d["contact_names"] == names
    np.testing.assert_array_equal(
        np.frombuffer(__import__("base64").b64decode(d["contacts"]), np.uint8).reshape(c.shape),
        c)
    h = body_height(m)
    assert d["metrics"]["sliding"] == pytest.approx(foot_sliding(m, c, names) / h)
    assert d["metrics"]["jitter"] == pytest.approx(mlayer.metrics.jitter(m, fps=m.fps) / h)


def _process(server, q):
    return get_json(server, f"/api/process?clip=0&{q}")


def test_process_matches_the_library(server, mocap):
    """The viewer's pipeline is mlayer.Synthesis (synthesize, then the guards): check it
    against the library's stylize, with per-part alphas given as explicit joint names."""
    m = mlayer.read_bvh(mocap / WALK)
    parts = body_parts(m.joint_names, m.parents)
    joints = {n: (0.5 if p == "arms" else 1.8) for n, p in zip(m.joint_names, parts)
              if p in ("arms", "legs")}
    ref = mlayer.stylize(m, 1.3, joints, root_alpha=1.3)
    names, c = detect_contacts(m)
    d = _process(server, "alpha=1.3&arms=0.5&legs=1.8")
    J, E = m.n_joints, m.skeleton.n_end_sites
    pts = f32(d["positions"], (m.n_frames, J + E, 3))
    np.testing.assert_allclose(pts[:, :J], ref.positions(), atol=1e-3 * body_height(m))
    assert d["metrics"]["sliding"] == pytest.approx(foot_sliding(ref, c, names) / body_height(m))
    assert d["frames"] == m.n_frames and not d["cached"]
    assert _process(server, "alpha=1.3&arms=0.5&legs=1.8")["cached"]


def test_process_without_denoise_or_contacts_at_alpha_1_is_the_original(server, mocap):
    m = mlayer.read_bvh(mocap / WALK)
    d = _process(server, "alpha=1&denoise=0&contacts=0")
    J = m.n_joints
    pts = f32(d["positions"], (m.n_frames, -1, 3))[:, :J]
    np.testing.assert_allclose(pts, m.positions(), atol=1e-4 * body_height(m))
    # denoised (residual dropped) is smoother than the original
    den = _process(server, "alpha=1&denoise=1&contacts=0")
    assert den["metrics"]["jitter"] < 0.9 * d["metrics"]["jitter"]


def test_process_alpha_zero_is_the_base_layer(server, mocap):
    m = mlayer.read_bvh(mocap / WALK)
    L = mlayer.decompose(m)
    d = _process(server, "alpha=0&contacts=0")
    pts = f32(d["positions"], (m.n_frames, -1, 3))[:, :m.n_joints]
    np.testing.assert_allclose(pts, L.base.positions(), atol=1e-3 * body_height(m))
    # the chart data: the chosen joint's angle curves
    pl = d["plot"]
    assert pl["joint_name"] == m.joint_names[pl["joint"]]
    assert len(pl["t"]) == len(pl["original"]) == len(pl["base"]) == len(pl["control"])
    np.testing.assert_allclose(pl["processed"], pl["base"], atol=1e-6)
    ang = np.degrees(np.linalg.norm(quat.log(m.rot[:, pl["joint"]]), axis=-1))
    np.testing.assert_allclose(pl["original"], ang[:len(pl["original"])], atol=1e-9)
    assert _process(server, "joint=0")["plot"]["joint_name"] == m.joint_names[0]


def test_process_retiming(server, mocap):
    m = mlayer.read_bvh(mocap / WALK)
    d = _process(server, f"length={2 * m.duration}")
    assert d["frames"] == 2 * m.n_frames and d["fps"] == pytest.approx(m.fps)
    d = _process(server, "fps=30")
    assert d["frames"] == int((m.n_frames - 1) * 30 / m.fps + 1e-9) + 1 and d["fps"] == 30.0
    c = np.frombuffer(__import__("base64").b64decode(d["contacts"]), np.uint8)
    assert c.size == d["frames"] * 4 and c.any()
    w = _process(server, "warp=2")
    assert w["frames"] == m.n_frames
    src = f32(w["source_frame"], (-1,))
    assert src[0] == 0 and src[-1] == pytest.approx(m.n_frames - 1)
    assert np.all(np.diff(src) > 0) and np.abs(src - np.arange(m.n_frames)).max() > 5


def test_download_is_the_processed_bvh(server, mocap):
    status, headers, body = get(server, "/api/download?clip=0&alpha=2&arms=0.5")
    assert status == 200
    assert headers["Content-Disposition"] == \
        'attachment; filename="cmu_131_01_mj_style_walk_processed.bvh"'
    got = mlayer.read_bvh_string(body.decode())
    m = mlayer.read_bvh(mocap / WALK)
    assert got.joint_names == m.joint_names and got.n_frames == m.n_frames
    d = _process(server, "alpha=2&arms=0.5")
    pts = f32(d["positions"], (m.n_frames, -1, 3))[:, :m.n_joints]
    np.testing.assert_allclose(got.positions(), pts, atol=1e-3 * body_height(m))


@requires("plot")
def test_layers_png(server):
    status, headers, body = get(server, "/api/layers.png?clip=2")
    assert status == 200 and headers["Content-Type"] == "image/png"
    assert body[:8] == b"\x89PNG\r\n\x1a\n" and len(body) > 10_000


def test_layers_png_without_matplotlib(server, monkeypatch):
    """Without the `plot` extra the figure is a 503 that names it; the viewer serves on."""
    monkeypatch.setitem(sys.modules, "matplotlib", None)
    status, _, body = get(server, "/api/layers.png?clip=0")
    assert status == 503 and b"pip install 'mlayer[plot]'" in body, body
    assert get(server, "/api/clips")[0] == 200


def test_slider_move_is_fast(server):
    """A slider move on a warm clip is one synthesize + contacts: well under a second (a loose
    bound: the figure is about 0.05 s on the machine this was written on)."""
    _process(server, "alpha=1.1")
    t0 = time.perf_counter()
    _process(server, "alpha=1.9&legs=0.3")
    assert time.perf_counter() - t0 < 2.0


def test_concurrent_requests(server):
    out = []

    def one(a):
        out.append(get(server, f"/api/process?clip=2&alpha={a}")[0])
    ts = [threading.Thread(target=one, args=(0.5 + 0.1 * k,)) for k in range(6)]
    for t in ts:
        t.start()
    for t in ts:
        t.join(60)
    assert out == [200] * 6


# ---- CLI --------------------------------------------------------------------------------------

def _start_cli(args):
    p = subprocess.Popen([sys.executable, "-m", "mlayer", "view", *args], stdout=subprocess.PIPE,
                         stderr=subprocess.PIPE, text=True)
    return p


def page_token(host, port):
    """The session token of the page a server at host:port serves (as the page's script reads
    it)."""
    import re
    c = http.client.HTTPConnection(host, port, timeout=30)
    c.request("GET", "/")
    html = c.getresponse().read().decode()
    c.close()
    return re.search(r'<meta name="mlayer-token" content="([^"]+)">', html).group(1)


def test_cli_prints_address_reports_bad_clip_and_serves(mocap, bad_clip):
    p = _start_cli([str(mocap / WALK), str(bad_clip)])
    try:
        line = p.stdout.readline()
        assert "serving 1 of 2 clip(s) at http://127.0.0.1:" in line, line
        url = line.split(" at ")[1].split()[0]
        host, port = urllib.parse.urlsplit(url).netloc.rsplit(":", 1)
        c = http.client.HTTPConnection(host, int(port), timeout=30)
        c.request("GET", "/api/clips", headers={"X-Mlayer-Token": page_token(host, int(port))})
        clips = json.loads(c.getresponse().read())["clips"]
        assert clips[0]["error"] is None and "broken.bvh" in clips[1]["error"]
    finally:
        p.terminate()
        _, err = p.communicate(timeout=10)
    assert f"mlayer view: error: {bad_clip}:6:" in err


def test_cli_serves_an_error_page_when_no_clip_parses(bad_clip, tmp_path):
    p = _start_cli([str(bad_clip), str(tmp_path / "missing.bvh")])
    try:
        line = p.stdout.readline()
        assert "serving 0 of 2 clip(s)" in line
        port = int(line.split(" at ")[1].split()[0].rstrip("/").rsplit(":", 1)[1])
        c = http.client.HTTPConnection("127.0.0.1", port, timeout=30)
        c.request("GET", "/api/clips", headers={"X-Mlayer-Token": page_token("127.0.0.1", port)})
        clips = json.loads(c.getresponse().read())["clips"]
        assert "No such file" in clips[1]["error"]
    finally:
        p.terminate()
        _, err = p.communicate(timeout=10)
    assert "no clip could be loaded" in err and "missing.bvh: No such file" in err


def test_cli_warns_off_loopback(mocap, monkeypatch, capsys):
    from mlayer import cli
    from mlayer.viewer import server as srv
    monkeypatch.setattr(srv.ViewerServer, "serve_forever", lambda self, **kw: None)
    monkeypatch.setattr(srv.ViewerServer, "warm", lambda self: None)
    assert cli.main(["view", str(mocap / WALK), "--host", "0.0.0.0"]) == 0
    err = capsys.readouterr().err
    assert "warning: serving on 0.0.0.0, not on loopback" in err
    assert cli.main(["view", str(mocap / WALK)]) == 0
    assert "warning" not in capsys.readouterr().err


def test_cli_bad_port(mocap, capsys):
    from mlayer import cli
    assert cli.main(["view", str(mocap / WALK), "--port", "70000"]) == 1
    assert "--port must be in 0..65535" in capsys.readouterr().err


def test_host_header_checked_on_a_wildcard_address(mocap):
    """Issue 39: bound to 0.0.0.0, the page and its token were served for any Host header and
    the API accepted that Origin (a DNS-rebinding page got full access). Now only the names it
    serves under (loopback, this machine's, --allow-host) are answered, and two Host headers
    are refused."""
    import socket
    srv = make_server([mocap / WALK], "0.0.0.0", log=sys.stderr,
                      allow_hosts=["viewer.lan", "proxy.example:8443"])
    t = threading.Thread(target=srv.serve_forever, kwargs={"poll_interval": 0.05}, daemon=True)
    t.start()
    try:
        port = srv.server_address[1]
        status, _, body = get(srv, "/", host=f"rebind.attacker.example:{port}", token=False)
        assert status == 403 and b"allow-host" in body
        assert get(srv, "/api/clips", host=f"rebind.attacker.example:{port}")[0] == 403
        for ok in (f"127.0.0.1:{port}", f"localhost:{port}", f"viewer.lan:{port}",
                   "proxy.example:8443", f"{socket.gethostname()}:{port}"):
            assert get(srv, "/api/clips", host=ok)[0] == 200, ok
        # two Host headers, the server's own first
        c = http.client.HTTPConnection("127.0.0.1", port, timeout=30)
        try:
            c.putrequest("GET", "/api/clips", skip_host=True)
            c.putheader("Host", f"127.0.0.1:{port}")
            c.putheader("Host", "rebind.attacker.example")
            c.putheader("X-Mlayer-Token", srv.token)
            c.endheaders()
            r = c.getresponse()
            assert r.status == 400 and b"Host headers" in r.read()
        finally:
            c.close()
    finally:
        srv.shutdown()
        srv.server_close()
        t.join(5)
    with pytest.raises(mlayer.InvalidArgumentError, match="allow-host"):
        make_server([mocap / WALK], "127.0.0.1", allow_hosts=["bad host"])


def test_http_0_9_request_is_answered_400(server):
    """Issue 39: "GET /" alone (HTTP/0.9) got no answer, and a traceback on the server (the
    handler waited for headers HTTP/0.9 does not send, then wrote an answer without a status
    line)."""
    import socket
    s = socket.create_connection(("127.0.0.1", server.server_address[1]), timeout=5)
    try:
        s.sendall(b"GET /\r\n")
        head = s.recv(4096).split(b"\r\n", 1)[0]
    finally:
        s.close()
    assert head.startswith(b"HTTP/1.") and b" 400 " in head
