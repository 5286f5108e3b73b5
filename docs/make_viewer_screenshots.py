"""Take the screenshots of docs/viewer.md: `mlayer view` on the bundled clip in headless chromium.

    python docs/make_viewer_screenshots.py [OUT_DIR]      # default docs/img

Needs what bindings/python/tests/viewer/test_viewer_browser.py needs: Debian's chromium and
chromium-driver (`apt-get install chromium chromium-driver`, as scripts/setup.sh does) and
selenium (`pip install selenium`), and Pillow. Writes viewer.png (the page after the alpha
slider moved to about 2.35, paused at frame 400), viewer_manifold.png (the motion manifold
panel after learning it and clicking two points on the map, paused at frame 60: the poses along
the spline on the map, the key-pose column, the pose strip) and viewer_manifold_generated.png
(the panel after generating 80 frames from frame 400 by the most likely transitions, paused at
frame 40: paper 2, Figures 6 and 7).
"""
from __future__ import annotations

import io
import os
import sys
import threading
import time
from pathlib import Path

CHROMIUM = os.environ.get("MLR_CHROMIUM", "/usr/bin/chromium")
CHROMEDRIVER = os.environ.get("MLR_CHROMEDRIVER", "/usr/bin/chromedriver")


def _wait(cond, timeout: float = 60.0, what: str = "condition"):
    t0 = time.monotonic()
    while True:
        v = cond()
        if v:
            return v
        if time.monotonic() - t0 > timeout:
            raise SystemExit(f"timed out after {timeout:g} s waiting for {what}")
        time.sleep(0.05)


def _browser():
    from selenium import webdriver
    from selenium.webdriver.chrome.service import Service
    opts = webdriver.ChromeOptions()
    opts.binary_location = CHROMIUM
    for a in ("--headless=new", "--no-sandbox", "--disable-dev-shm-usage", "--disable-gpu",
              "--window-size=1280,1000", "--force-device-scale-factor=1",
              "--disable-extensions", "--no-first-run", "--disable-background-networking"):
        opts.add_argument(a)
    return webdriver.Chrome(service=Service(CHROMEDRIVER), options=opts)


def _save(png: bytes, path: Path) -> None:
    """A PNG with a palette of 256 colours: the screenshots stay small in the repository."""
    from PIL import Image
    img = Image.open(io.BytesIO(png)).convert("RGB")
    img.quantize(colors=256, method=Image.Quantize.MEDIANCUT).save(path, optimize=True)
    print(f"wrote {path} ({img.width}x{img.height}, {path.stat().st_size // 1024} KiB)")


def main(argv: list[str]) -> int:
    from selenium.webdriver.common.action_chains import ActionChains

    import mlayer
    from mlayer.viewer import make_server
    out = Path(argv[0]) if argv else Path(__file__).resolve().parent / "img"
    out.mkdir(parents=True, exist_ok=True)
    srv = make_server([mlayer.data.sample_path()], log=sys.stderr, manifold_frames=600)
    t = threading.Thread(target=srv.serve_forever, kwargs={"poll_interval": 0.05}, daemon=True)
    t.start()
    d = _browser()

    def js(expr: str):
        return d.execute_script(f"return {expr};")

    def settled():
        return js("window.mlayerViewer && mlayerViewer.ready && !mlayerViewer.state.inflight "
                  "&& !mlayerViewer.state.pending && mlayerViewer.drawn !== null")

    try:
        d.get(srv.url)
        _wait(settled, what="the page to load the clip")
        el = d.find_element("id", "alpha")
        n = js("mlayerViewer.state.responses")
        ActionChains(d).move_to_element_with_offset(el, int(0.25 * el.size["width"]), 0) \
            .click().perform()
        _wait(lambda: js("mlayerViewer.state.responses") > n, what="the server's answer")
        _wait(settled, what="the answer to be applied")
        d.execute_script("mlayerViewer.pause(); mlayerViewer.setFrame(400);")
        _wait(lambda: js("mlayerViewer.drawn && mlayerViewer.drawn.procFrame === 400"),
              what="frame 400")
        time.sleep(0.3)
        _save(d.get_screenshot_as_png(), out / "viewer.png")

        d.find_element("id", "m-train").click()
        _wait(lambda: js("mlayerViewer.manifold.state.state") in ("ready", "failed"), 180,
              "the manifold to be learned")
        if js("mlayerViewer.manifold.state.state") != "ready":
            raise SystemExit("the manifold failed: " + d.find_element("id", "m-status").text)
        cv = d.find_element("id", "m-map")
        d.execute_script("arguments[0].scrollIntoView({block: 'center'});", cv)
        time.sleep(0.3)
        w, h = cv.size["width"], cv.size["height"]
        for fx, fy in ((0.2, 0.8), (0.8, 0.25)):
            n = js("mlayerViewer.manifold.state.responses")
            ActionChains(d).move_to_element_with_offset(cv, int((fx - 0.5) * w),
                                                        int((fy - 0.5) * h)).click().perform()
            _wait(lambda: js("mlayerViewer.manifold.state.responses") > n
                  and not js("mlayerViewer.manifold.state.inflight"), 60, "the manifold motion")
        panel = d.find_element("id", "m-map")
        # the panel holding the map: its nearest section (or the map's parent)
        panel = d.execute_script("return arguments[0].closest('section, fieldset, .panel') "
                                 "|| arguments[0].parentElement;", panel)

        def shot(frame: int, name: str) -> None:
            d.execute_script(f"mlayerViewer.manifold.pause(); "
                             f"mlayerViewer.manifold.setFrame({frame});")
            _wait(lambda: js(f"mlayerViewer.manifold.drawn.frame === {frame}"),
                  what=f"manifold frame {frame}")
            d.execute_script("arguments[0].scrollIntoView();", panel)
            time.sleep(0.5)
            _save(panel.screenshot_as_png, out / name)

        d.set_window_size(1280, 1400)  # the whole panel in view, strip included
        shot(60, "viewer_manifold.png")
        # 80 frames from frame 400 by the most likely transitions (paper Figures 6 and 7)
        from selenium.webdriver.common.keys import Keys
        from selenium.webdriver.support.ui import Select
        el = d.find_element("id", "m-frames")
        el.send_keys(Keys.CONTROL, "a")
        el.send_keys("80")
        el = d.find_element("id", "m-start-frame")
        el.send_keys(Keys.CONTROL, "a")
        el.send_keys("400", Keys.TAB)
        Select(d.find_element("id", "m-chain")).select_by_value("most")
        _wait(lambda: not js("mlayerViewer.manifold.state.inflight")
              and not js("mlayerViewer.manifold.state.pending"), 60, "the requests")
        n = js("mlayerViewer.manifold.state.responses")
        d.find_element("id", "m-generate").click()
        _wait(lambda: js("mlayerViewer.manifold.state.responses") > n
              and not js("mlayerViewer.manifold.state.inflight"), 60, "the generated motion")
        shot(40, "viewer_manifold_generated.png")
    finally:
        d.quit()
        srv.shutdown()
        srv.server_close()
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
