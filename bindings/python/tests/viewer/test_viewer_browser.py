"""mlayer view end to end in a real headless browser: Debian's chromium driven by Selenium
through /usr/bin/chromedriver (both from apt; scripts/setup.sh installs them; nothing is
downloaded). Skipped, with the reason, only when chromium, chromedriver or selenium is missing.

Set MLR_VIEWER_SCREENSHOT=path.png to keep the screenshot taken after the slider move.
"""
import io
import os
import sys
import threading
import time
import urllib.parse

import numpy as np
import pytest

import mlayer
from mlayer.viewer import make_server
from mlayer.viewer.session import PARAMS, parse_params

CHROMIUM = os.environ.get("MLR_CHROMIUM", "/usr/bin/chromium")
CHROMEDRIVER = os.environ.get("MLR_CHROMEDRIVER", "/usr/bin/chromedriver")
WALK = "cmu_131_01_mj_style_walk.bvh"


def _missing() -> str | None:
    for path, pkg in ((CHROMIUM, "chromium"), (CHROMEDRIVER, "chromium-driver")):
        if not (os.path.isfile(path) and os.access(path, os.X_OK)):
            return (f"{path} not found: the browser tests need Debian's {pkg} (apt-get install "
                    f"-y chromium chromium-driver, as scripts/setup.sh does)")
    try:
        import selenium  # noqa: F401
    except ImportError:
        return "selenium is not installed (pip install selenium, as scripts/setup.sh does)"
    return None


pytestmark = pytest.mark.skipif(_missing() is not None, reason=_missing() or "")


@pytest.fixture(scope="module")
def downloads(tmp_path_factory):
    return tmp_path_factory.mktemp("downloads")


@pytest.fixture(scope="module")
def browser(downloads):
    from selenium import webdriver
    from selenium.webdriver.chrome.service import Service
    opts = webdriver.ChromeOptions()
    opts.binary_location = CHROMIUM
    for a in ("--headless=new", "--no-sandbox", "--disable-dev-shm-usage", "--disable-gpu",
              "--window-size=1400,1100", "--force-device-scale-factor=1",
              "--disable-extensions", "--no-first-run", "--disable-background-networking"):
        opts.add_argument(a)
    opts.add_experimental_option("prefs", {
        "download.default_directory": str(downloads), "download.prompt_for_download": False,
        "safebrowsing.enabled": False})
    d = webdriver.Chrome(service=Service(CHROMEDRIVER), options=opts)
    d.set_page_load_timeout(60)
    try:
        d.execute_cdp_cmd("Page.setDownloadBehavior",
                          {"behavior": "allow", "downloadPath": str(downloads)})
    except Exception:  # older drivers: the prefs above do it
        pass
    yield d
    d.quit()


def _serve(paths, **limits):
    srv = make_server(paths, log=sys.stderr, **limits)
    t = threading.Thread(target=srv.serve_forever, kwargs={"poll_interval": 0.05}, daemon=True)
    t.start()
    return srv, t


@pytest.fixture(scope="module")
def server(mocap, tmp_path_factory):
    bad = tmp_path_factory.mktemp("bad") / "broken.bvh"
    bad.write_text("HIERARCHY\nROOT Hips\n{\n  OFFSET 0 0 zero\n}\n")
    srv, t = _serve([mocap / WALK, bad], manifold_frames=300)  # the manifold: 249 frames
    srv.warm().join(60)
    yield srv
    srv.shutdown()
    srv.server_close()
    t.join(5)


def wait(cond, timeout=30.0, what="condition"):
    t0 = time.monotonic()
    while True:
        v = cond()
        if v:
            return v
        if time.monotonic() - t0 > timeout:
            raise AssertionError(f"timed out after {timeout:g} s waiting for {what}")
        time.sleep(0.05)


def js(d, expr):
    return d.execute_script(f"return {expr};")


def settled(d):
    """No request in flight or pending, and the figure drawn after the last answer."""
    return js(d, "window.mlayerViewer && mlayerViewer.ready && !mlayerViewer.state.inflight "
                 "&& !mlayerViewer.state.pending && mlayerViewer.drawn !== null")


def open_page(d, srv):
    d.get(srv.url)
    wait(lambda: settled(d), what="the page to load the first clip")


def drawn_at(d, frame):
    """Pause at a frame and return the world positions drawn there (after a repaint)."""
    d.execute_script(f"mlayerViewer.pause(); mlayerViewer.setFrame({frame});")
    wait(lambda: js(d, f"mlayerViewer.drawn && mlayerViewer.drawn.procFrame === {frame}"),
         what=f"frame {frame} to be drawn")
    time.sleep(0.1)  # one more animation frame
    dr = js(d, "mlayerViewer.drawn")
    return np.array(dr["processed"]), np.array(dr["original"])


def move_slider(d, element_id, fraction):
    """Click the range input at `fraction` of its width, as a user would."""
    from selenium.webdriver.common.action_chains import ActionChains
    el = d.find_element("id", element_id)
    w = el.size["width"]
    ActionChains(d).move_to_element_with_offset(el, int((fraction - 0.5) * w), 0).click() \
        .perform()
    return el


def test_page_plays_and_alpha_slider_changes_the_pose(browser, server, mocap, downloads,
                                                      tmp_path):
    d = browser
    open_page(d, server)
    assert js(d, "document.getElementById('status').className") == ""
    # it plays by itself
    f0 = js(d, "mlayerViewer.drawn.procFrame")
    wait(lambda: js(d, "mlayerViewer.drawn.procFrame") != f0, 10, "playback to advance")

    before, orig_before = drawn_at(d, 400)
    slide_before = d.find_element("id", "slide-proc").text
    jitter_before = d.find_element("id", "jitter-proc").text
    n_resp = js(d, "mlayerViewer.state.responses")
    assert slide_before not in ("", "–") and "alpha=1&" in js(d, "mlayerViewer.state.lastQuery")

    el = move_slider(d, "alpha", 0.92)
    value = float(el.get_attribute("value"))
    assert value > 2.4
    wait(lambda: js(d, "mlayerViewer.state.responses") > n_resp, what="the server's answer")
    wait(lambda: settled(d), what="the answer to be applied")
    assert js(d, "mlayerViewer.state.lastError") is None
    assert f"alpha={value:g}" in js(d, "mlayerViewer.state.lastQuery")
    assert d.find_element("id", "alpha-out").text == f"{value:.2f}"

    after, orig_after = drawn_at(d, 400)
    m = mlayer.read_bvh(mocap / WALK)
    h = mlayer.metrics.body_height(m)
    moved = np.linalg.norm(after - before, axis=1)
    assert moved.max() > 0.02 * h, f"pose barely changed: {moved.max():.4g} units"
    np.testing.assert_allclose(orig_after, orig_before)  # the original stays as it was
    # the figure matches the server's processed motion at that frame
    q = dict(urllib.parse.parse_qsl(js(d, "mlayerViewer.state.lastQuery")))
    p = parse_params(urllib.parse.urlencode(q), tuple(PARAMS))
    _, proc = server.clips[0].process(p)
    np.testing.assert_allclose(after, proc.positions()[400], atol=1e-4 * h)
    # the metrics updated
    assert d.find_element("id", "slide-proc").text != slide_before
    assert d.find_element("id", "jitter-proc").text != jitter_before

    # a screenshot: not blank, the figure canvas has lines of several colours
    from PIL import Image
    png = d.get_screenshot_as_png()
    keep = os.environ.get("MLR_VIEWER_SCREENSHOT")
    for path in [tmp_path / "viewer.png"] + ([keep] if keep else []):
        with open(path, "wb") as f:
            f.write(png)
    img = np.asarray(Image.open(io.BytesIO(png)).convert("RGB")).astype(int)
    assert img.shape[0] > 500 and img.shape[1] > 900
    assert img.std() > 10 and len(np.unique(img.reshape(-1, 3), axis=0)) > 100
    canvas = np.asarray(Image.open(io.BytesIO(
        d.find_element("id", "figure").screenshot_as_png)).convert("RGB")).astype(int)
    ink = (canvas < 235).any(axis=-1)
    assert 0.003 < ink.mean() < 0.6, f"figure canvas coverage {ink.mean():.4f}"
    red = (canvas[..., 0] > 150) & (canvas[..., 1] < 110) & (canvas[..., 2] < 110)
    blue = (canvas[..., 2] > 150) & (canvas[..., 0] < 110)
    green = (canvas[..., 1] > 120) & (canvas[..., 0] < 90) & (canvas[..., 2] < 120)
    assert red.sum() > 50 and blue.sum() > 50, "left/right limbs not drawn"
    assert green.sum() > 10, "no contact drawn on the feet"

    # download: a real click, the file lands in the download folder and parses
    for f in downloads.iterdir():
        f.unlink()
    d.find_element("id", "download").click()
    done = wait(lambda: [f for f in downloads.iterdir() if f.suffix == ".bvh"], 30,
                "the download")
    text = done[0].read_text()
    assert done[0].name == "cmu_131_01_mj_style_walk_processed.bvh"
    got = mlayer.read_bvh_string(text, done[0].name)
    assert got.joint_names == m.joint_names and got.n_frames == m.n_frames
    np.testing.assert_allclose(got.positions()[400], after, atol=1e-3 * h)

    # the layer figure: an <img> cannot send a header, its URL carries the session token
    d.find_element("css selector", "#figure-details summary").click()
    wait(lambda: js(d, "document.getElementById('layers-png').naturalWidth") > 100, 60,
         "the layer figure")
    assert "token=" in js(d, "document.getElementById('layers-png').src")


def test_parts_denoise_retiming_and_camera(browser, server, mocap):
    from selenium.webdriver.common.action_chains import ActionChains
    from selenium.webdriver.common.keys import Keys
    d = browser
    open_page(d, server)
    m = mlayer.read_bvh(mocap / WALK)

    def after(action, what):
        n = js(d, "mlayerViewer.state.responses")
        action()
        wait(lambda: js(d, "mlayerViewer.state.responses") > n, what=what)
        wait(lambda: settled(d), what=what)
        assert js(d, "mlayerViewer.state.lastError") is None
        return js(d, "mlayerViewer.state.lastQuery")

    # a part slider unlinks that part only
    q = after(lambda: move_slider(d, "arms", 0.05), "the arms slider")
    assert "arms=" in q and "legs=" not in q and "spine=" not in q
    q = after(lambda: d.find_element("id", "reset-parts").click(), "the reset button")
    assert "arms=" not in q
    q = after(lambda: d.find_element("id", "denoise").click(), "the denoise box")
    assert "denoise=0" in q
    q = after(lambda: d.find_element("id", "contacts").click(), "the contacts box")
    assert "contacts=0" in q
    # retiming: longer clip, more frames on the scrub bar
    el = d.find_element("id", "length")
    q = after(lambda: el.send_keys(Keys.END), "the length slider")
    assert f"length={2 * m.duration:.6f}" in q
    assert int(d.find_element("id", "scrub").get_attribute("max")) == 2 * m.n_frames - 1
    q = after(lambda: move_slider(d, "warp", 0.5), "the warp slider")
    assert "warp=" in q
    from selenium.webdriver.support.ui import Select
    q = after(lambda: Select(d.find_element("id", "fps")).select_by_value("30"), "fps")
    assert "fps=30" in q and d.find_element("id", "frames-proc").text.endswith("@ 30")
    # orbit by drag, zoom by wheel
    cv = d.find_element("id", "figure")
    yaw, zoom = js(d, "mlayerViewer.state.cam.yaw"), js(d, "mlayerViewer.state.cam.zoom")
    ActionChains(d).move_to_element(cv).click_and_hold().move_by_offset(120, 30).release() \
        .perform()
    assert js(d, "mlayerViewer.state.cam.yaw") != pytest.approx(yaw)
    d.execute_script("arguments[0].dispatchEvent(new WheelEvent('wheel', {deltaY: 300, "
                     "bubbles: true, cancelable: true}))", cv)
    assert js(d, "mlayerViewer.state.cam.zoom") > zoom
    # the layer chart was drawn
    assert js(d, "mlayerViewer.state.chart !== undefined")
    assert js(d, "mlayerViewer.state.proc.plot.processed.length") > 10


def test_alpha_keys_over_the_timeline(browser, server, mocap):
    """Alpha over time: keys set at the playhead with the global slider, the curve drawn under
    the chart, the figure the server's synthesis with the curve; bad keys shown as an error."""
    from selenium.webdriver.common.keys import Keys
    d = browser
    open_page(d, server)
    m = mlayer.read_bvh(mocap / WALK)
    h = mlayer.metrics.body_height(m)
    assert js(d, "document.getElementById('alpha-chart').hidden")

    def after(action, what):
        n = js(d, "mlayerViewer.state.responses")
        action()
        wait(lambda: js(d, "mlayerViewer.state.responses") > n, what=what)
        wait(lambda: settled(d), what=what)
        return js(d, "mlayerViewer.state.lastQuery")

    drawn_at(d, 120)  # 1 s at 120 fps
    after(lambda: move_slider(d, "alpha", 0.9), "the alpha slider")
    a_hi = float(d.find_element("id", "alpha").get_attribute("value"))
    after(lambda: d.find_element("id", "key-alpha").click(), "the first key")
    drawn_at(d, 480)  # 4 s
    after(lambda: move_slider(d, "alpha", 0.1), "the alpha slider")
    a_lo = float(d.find_element("id", "alpha").get_attribute("value"))
    q = after(lambda: d.find_element("id", "key-alpha").click(), "the second key")
    assert js(d, "mlayerViewer.state.lastError") is None
    keys = d.find_element("id", "alpha-keys").get_attribute("value")
    assert keys == f"1:{a_hi:g},4:{a_lo:g}" and a_hi > 2 and a_lo < 0.6
    assert "keys=" in q
    ac = js(d, "mlayerViewer.state.proc.alphaCurve")
    assert ac["keys"] == [[1.0, a_hi], [4.0, a_lo]]
    assert max(ac["alpha"]) == pytest.approx(a_hi) and min(ac["alpha"]) == pytest.approx(a_lo)
    # the curve is drawn under the chart
    assert not js(d, "document.getElementById('alpha-chart').hidden")
    from PIL import Image
    img = np.asarray(Image.open(io.BytesIO(
        d.find_element("id", "alpha-chart").screenshot_as_png)).convert("RGB")).astype(int)
    green = (img[..., 1] > 120) & (img[..., 0] < 90) & (img[..., 2] < 120)
    assert green.sum() > 100, "the alpha curve is not drawn"
    # the figure is the server's synthesis with the curve, which mlayer.stylize gives too
    after_pose, _ = drawn_at(d, 300)
    p = parse_params(urllib.parse.urlencode(dict(urllib.parse.parse_qsl(q))), tuple(PARAMS))
    _, proc = server.clips[0].process(p)
    np.testing.assert_allclose(after_pose, proc.positions()[300], atol=1e-4 * h)
    const_pose = mlayer.stylize(m, a_lo).positions()[300]
    assert np.abs(proc.positions()[300] - const_pose).max() > 0.01 * h
    # bad keys: the server's message, one line
    el = d.find_element("id", "alpha-keys")
    el.clear()
    el.send_keys("0:1,x:2")
    n = js(d, "mlayerViewer.state.responses")
    el.send_keys(Keys.TAB)
    wait(lambda: js(d, "mlayerViewer.state.responses") > n, what="the bad keys' answer")
    assert "keys: alpha keys: key 1 'x:2'" in js(d, "mlayerViewer.state.lastError")
    after(lambda: d.find_element("id", "clear-keys").click(), "clear keys")
    assert js(d, "mlayerViewer.state.lastError") is None
    assert js(d, "document.getElementById('alpha-chart').hidden")
    d.get_log("browser")  # (the bad keys' 400 is expected: not a console error of the page)


def test_bad_clip_shows_its_error(browser, server):
    d = browser
    open_page(d, server)
    box = d.find_element("id", "errors")
    assert box.is_displayed()
    assert "broken.bvh" in box.text and ":4:" in box.text
    opts = d.find_elements("css selector", "#clip option")
    assert [o.get_attribute("disabled") for o in opts] == [None, "true"]


def test_error_page_when_no_clip_parses(browser, tmp_path):
    bad = tmp_path / "nothing.bvh"
    bad.write_text("this is not a BVH file\n")
    srv, t = _serve([bad])
    try:
        d = browser
        d.get(srv.url)
        wait(lambda: js(d, "window.mlayerViewer && mlayerViewer.ready"), what="the error page")
        assert "no clip could be loaded" in d.find_element("id", "status").text
        assert "nothing.bvh" in d.find_element("id", "errors").text
        assert not d.find_element("id", "main").is_displayed()
    finally:
        srv.shutdown()
        srv.server_close()
        t.join(5)


def test_no_console_errors(browser, server):
    d = browser
    open_page(d, server)
    logs = [e for e in d.get_log("browser") if e["level"] == "SEVERE"]
    assert logs == []


def test_manifold_click_play_and_download(browser, server, mocap, downloads):
    """Learn the manifold, click two points on the map: the spline's motion plays in the
    manifold figure (it moves, and it is the server's motion), the download parses; then the
    key-frame picker and the second-likely chain."""
    from selenium.webdriver.common.action_chains import ActionChains
    from selenium.webdriver.support.ui import Select
    from mlayer.viewer.manifold import ranked_chain
    d = browser
    open_page(d, server)
    d.find_element("id", "m-train").click()
    wait(lambda: js(d, "mlayerViewer.manifold.state.state") in ("ready", "failed"), 120,
         "the manifold to be learned")
    assert js(d, "mlayerViewer.manifold.state.state") == "ready", \
        d.find_element("id", "m-status").text
    assert "SOM 15×15 on 249 frames" in d.find_element("id", "m-status").text
    md = server.manifold.model
    cv = d.find_element("id", "m-map")
    w, h = cv.size["width"], cv.size["height"]

    def responses():
        return js(d, "mlayerViewer.manifold.state.responses")

    def click_map(fx, fy):
        n = responses()
        ActionChains(d).move_to_element_with_offset(cv, int((fx - 0.5) * w),
                                                    int((fy - 0.5) * h)).click().perform()
        wait(lambda: responses() > n and not js(d, "mlayerViewer.manifold.state.inflight"),
             60, "the manifold motion")
        assert js(d, "mlayerViewer.manifold.state.lastError") is None

    # the map canvas: the regions in colour under the U-matrix
    from PIL import Image
    img = np.asarray(Image.open(io.BytesIO(cv.screenshot_as_png)).convert("RGB")).astype(int)
    assert len(np.unique(img.reshape(-1, 3) // 16, axis=0)) > 2 * md.centers.shape[0]
    assert (img.max(-1) - img.min(-1)).mean() > 10, "no colour on the map"

    click_map(0.15, 0.85)   # low left: row small, column small
    click_map(0.85, 0.2)    # up right
    pts = np.array(js(d, "mlayerViewer.manifold.state.points"))
    assert pts.shape == (2, 2)
    assert pts[0, 0] < 4 and pts[0, 1] < 4 and pts[1, 0] > 10 and pts[1, 1] > 10
    q = js(d, "mlayerViewer.manifold.state.lastQuery")
    assert q.startswith("points=") and "frames=120" in q
    assert js(d, "mlayerViewer.manifold.state.motion.frames") == 120

    def drawn(frame):
        d.execute_script(f"mlayerViewer.manifold.pause(); "
                         f"mlayerViewer.manifold.setFrame({frame});")
        wait(lambda: js(d, f"mlayerViewer.manifold.drawn.frame === {frame}"),
             what=f"manifold frame {frame}")
        return np.array(js(d, "mlayerViewer.manifold.drawn.positions"))

    a, b = drawn(0), drawn(119)
    _, ref = server.manifold.motion(q)
    hgt = mlayer.metrics.body_height(ref)
    assert np.linalg.norm(b - a, axis=1).max() > 0.05 * hgt, "the figure does not move"
    np.testing.assert_allclose(a, ref.positions()[0], atol=1e-4 * hgt)
    np.testing.assert_allclose(b, ref.positions()[119], atol=1e-4 * hgt)
    # the figure canvas shows it
    fig = np.asarray(Image.open(io.BytesIO(
        d.find_element("id", "m-figure").screenshot_as_png)).convert("RGB")).astype(int)
    assert 0.002 < (fig < 235).any(-1).mean() < 0.6

    # download: a real click, the file parses, the requested frames
    for f in downloads.iterdir():
        f.unlink()
    d.find_element("id", "m-download").click()
    done = wait(lambda: [f for f in downloads.iterdir() if f.suffix == ".bvh"], 30,
                "the manifold download")
    assert done[0].name == "manifold_points.bvh"
    got = mlayer.read_bvh_string(done[0].read_text(), done[0].name)
    assert got.n_frames == 120 and got.joint_names == ref.joint_names
    np.testing.assert_allclose(got.positions()[119], b, atol=1e-3 * hgt)

    # key frames from the loaded clip: their BMUs are the knots
    for frame in (20, 600):
        el = d.find_element("id", "m-key-frame")
        el.clear()
        el.send_keys(str(frame))
        d.find_element("id", "m-key-add").click()
    assert d.find_element("id", "m-keys").text == "0:20, 0:600"
    n = responses()
    d.find_element("id", "m-key-go").click()
    wait(lambda: responses() > n and not js(d, "mlayerViewer.manifold.state.inflight"), 60,
         "the key-frame motion")
    assert js(d, "mlayerViewer.manifold.state.lastError") is None
    from mlayer.manifold.features import pose_features
    walk = mlayer.read_bvh(mocap / WALK)
    np.testing.assert_allclose(js(d, "mlayerViewer.manifold.state.motion.knots"),
                               md.to_manifold(pose_features(walk)[[20, 600]]))

    # a start frame with the second most likely transitions
    el = d.find_element("id", "m-start-frame")
    el.clear()
    el.send_keys("400")
    Select(d.find_element("id", "m-chain")).select_by_value("second")
    n = responses()
    d.find_element("id", "m-generate").click()
    wait(lambda: responses() > n and not js(d, "mlayerViewer.manifold.state.inflight"), 60,
         "the generated motion")
    assert js(d, "mlayerViewer.manifold.state.lastError") is None
    assert "chain=second" in js(d, "mlayerViewer.manifold.state.lastQuery")
    want = ranked_chain(md.markov, int(md.labels[100]), 120, 2)
    assert js(d, "mlayerViewer.manifold.state.motion.primitives") == [int(v) for v in want]
    logs = [e for e in d.get_log("browser") if e["level"] == "SEVERE"]
    assert logs == []


def _png(el):
    from PIL import Image
    return np.asarray(Image.open(io.BytesIO(el.screenshot_as_png)).convert("RGB")).astype(int)


def _near(img, rgb, tol=40):
    """Pixels within tol of an RGB colour (per channel)."""
    return (np.abs(img - np.asarray(rgb)[None, None]) <= tol).all(-1)


def test_manifold_paper_figures(browser, server, mocap):
    """The paper's figures in the manifold panel: the key-pose column (Figs. 2 (b) and 5), the
    poses drawn along the spline through clicked points (Fig. 4), and a generated sequence as
    a pose strip over each frame's primitive memberships (Figs. 6 and 7): counts, the server's
    numbers, and the pixels of the canvases."""
    from scipy.spatial.distance import cdist
    from selenium.webdriver.common.action_chains import ActionChains
    from selenium.webdriver.common.keys import Keys
    from selenium.webdriver.support.ui import Select
    d = browser
    open_page(d, server)
    d.find_element("id", "m-train").click()   # kept from an earlier test, else learned now
    wait(lambda: js(d, "mlayerViewer.manifold.state.state") in ("ready", "failed"), 120,
         "the manifold to be learned")
    assert js(d, "mlayerViewer.manifold.state.state") == "ready"
    md = server.manifold.model
    k = md.centers.shape[0]
    M = "mlayerViewer.manifold.state"

    def color(j):
        return js(d, f"mlayerViewer.manifold.colorOf({j})")

    # ---- the key-pose column: k figures, each in its primitive's colour, in its own cell
    col = js(d, f"{M}.column")
    assert col["count"] == k == len(col["cells"]) and col["highlight"] == -1
    cv = d.find_element("id", "m-keyposes")
    d.execute_script("arguments[0].scrollIntoView({block: 'start'})", cv)
    img = _png(cv)
    assert img.shape[0] == k * col["cell"] + 2  # the canvas and its border
    for j, c in enumerate(col["cells"]):
        cell = img[1 + c["top"]:1 + c["bottom"]]
        assert _near(cell, color(j)).sum() > 60, f"no figure of primitive {j}"
        others = [i for i in range(k) if i != j and color(i) != color(j)]
        assert all(_near(cell, color(i), 10).sum() < 5 for i in others)
        x0, y0, x1, y1 = c["box"]
        assert y1 - y0 > 0.5 * col["cell"] and c["top"] <= y0 < y1 <= c["bottom"]

    # ---- Fig. 4: two clicks, poses along the spline on the map
    cv = d.find_element("id", "m-map")
    d.execute_script("arguments[0].scrollIntoView({block: 'center'})", cv)
    w, h = cv.size["width"], cv.size["height"]
    d.find_element("id", "m-clear").click()
    for fx, fy in ((0.15, 0.85), (0.85, 0.2)):
        n = js(d, f"{M}.responses")
        ActionChains(d).move_to_element_with_offset(cv, int((fx - 0.5) * w),
                                                    int((fy - 0.5) * h)).click().perform()
        wait(lambda n=n: js(d, f"{M}.responses") > n and not js(d, f"{M}.inflight"), 60,
             "the manifold motion")
        assert js(d, f"{M}.lastError") is None
    d.execute_script("mlayerViewer.manifold.pause(); mlayerViewer.manifold.setFrame(60);")
    wait(lambda: js(d, "mlayerViewer.manifold.drawn.frame === 60"), what="frame 60")
    n_frames = js(d, f"{M}.motion.frames")
    figs = js(d, f"{M}.overlay.figures")
    frames = [f["frame"] for f in figs]
    assert frames == sorted(set(frames)) and frames[0] == 0 and frames[-1] == n_frames - 1
    assert [f["kind"] for f in figs if f["kind"] != "between"] == ["knot", "last"]
    assert len(figs) >= 6
    traj = np.array(js(d, f"{M}.motion.traj"))
    for f in figs:  # each figure hangs at its frame's point of the path
        x, y = js(d, f"mlayerViewer.manifold.toCanvas({traj[f['frame'], 0]}, "
                     f"{traj[f['frame'], 1]})")
        assert (f["x"], f["y"]) == pytest.approx((x, y))
    on = _png(cv)
    d.find_element("id", "m-poses").click()   # off: the map without the figures
    wait(lambda: js(d, f"{M}.overlay.figures.length") == 0, what="the figures to go")
    off = _png(cv)
    changed = np.abs(on - off).max(-1) > 30
    inside = np.zeros_like(changed)
    for f in figs:
        x0, y0, x1, y1 = (int(round(v)) for v in f["box"])
        inside[max(0, y0 - 3):y1 + 5, max(0, x0 - 3):x1 + 5] = True
    assert changed.sum() > 40 * len(figs), "the figures do not show on the map"
    assert changed[~inside].sum() < 0.02 * changed.sum()
    x0, y0, x1, y1 = (int(round(v)) for v in figs[-1]["box"])
    assert _near(on[y0:y1 + 2, x0:x1 + 2], (214, 39, 40)).sum() > 10  # the last point's, red
    d.find_element("id", "m-poses").click()
    wait(lambda: js(d, f"{M}.overlay.figures.length") == len(figs), what="the figures back")

    # ---- Figs. 6 and 7: 80 frames from a start frame, most likely transitions
    el = d.find_element("id", "m-frames")
    el.send_keys(Keys.CONTROL, "a")   # typed over, not cleared (clear() sends a change event)
    el.send_keys("80")
    el = d.find_element("id", "m-start-frame")
    el.clear()
    el.send_keys("400", Keys.TAB)
    Select(d.find_element("id", "m-chain")).select_by_value("most")
    wait(lambda: not js(d, f"{M}.inflight") and not js(d, f"{M}.pending"), 60, "the requests")
    n = js(d, f"{M}.responses")
    d.find_element("id", "m-generate").click()
    wait(lambda: js(d, f"{M}.responses") > n and not js(d, f"{M}.inflight")
         and js(d, f"{M}.motion.kind") == "start", 60, "the generated motion")
    assert js(d, f"{M}.lastError") is None
    d.execute_script("mlayerViewer.manifold.pause(); mlayerViewer.manifold.setFrame(0);")
    wait(lambda: js(d, "mlayerViewer.manifold.drawn.frame === 0"), what="frame 0")
    strip = js(d, f"{M}.strip")
    assert js(d, f"{M}.motion.frames") == 80
    # the paper's strip: frames 1, 5, 9, ..., 77
    assert [f["frame"] + 1 for f in strip["figures"]] == list(range(1, 80, 4))
    assert strip["step"] == 4
    traj = np.array(js(d, f"{M}.motion.traj"))
    want = np.argmin(cdist(traj, md.centers, "sqeuclidean"), axis=1)
    memb = js(d, f"{M}.motion.membership")
    np.testing.assert_array_equal(memb, want)
    assert len(set(memb)) >= 2
    assert [f["primitive"] for f in strip["figures"]] == [int(want[f]) for f in range(0, 80, 4)]
    assert js(d, f"{M}.column.highlight") == int(want[0])
    sv = d.find_element("id", "m-strip")
    d.execute_script("arguments[0].scrollIntoView({block: 'center'})", sv)
    img = _png(sv)[1:-1, 1:-1]  # inside the border
    W = strip["width"]
    # the row under the bar: each frame's primitive of largest membership, in its colour
    yr = int(strip["rowTop"] + strip["rowH"] / 2)
    for f in range(3, 80):  # away from the playhead's marker at frame 0
        x = int(strip["L"] + (f + 0.5) * (W - strip["L"] - strip["R"]) / 80)
        assert np.abs(img[yr, x] - np.array(color(int(want[f])))).max() <= 2, f"frame {f}"
    # the bar: a frame's column holds the colours of its memberships, largest the most
    u = np.array(js(d, f"Array.from({M}.motion.memberships)")).reshape(80, k)
    for f in (20, 40, 60):
        x = int(strip["L"] + (f + 0.5) * (W - strip["L"] - strip["R"]) / 80)
        colm = img[int(strip["barTop"]) + 1:int(strip["barTop"] + strip["barH"]) - 1, x]
        top = int(np.argmax(u[f]))
        share = _near(colm[:, None], color(top), 2)[:, 0].mean()
        assert abs(share - u[f, top]) < 0.12, (f, share, u[f, top])
    # each strip figure drawn in its primitive's colour within its box
    for fig in strip["figures"]:
        x0, y0, x1, y1 = (int(round(v)) for v in fig["box"])
        assert _near(img[y0:y1 + 1, x0:x1 + 1], color(fig["primitive"])).sum() > 15
    logs = [e for e in d.get_log("browser") if e["level"] == "SEVERE"]
    assert logs == []
