#!/usr/bin/python3
"""The replay page in a real browser: headless Chromium driven through chromedriver's W3C WebDriver
HTTP protocol (standard library only, no selenium).

For a default-world EKF run, a FastSLAM run, a range-only EKF run with the ring start and a grid
FastSLAM run in the simulated office, each recorded with `slamkit run --replay`, it checks that the page is self-contained (no element loads
anything, the browser fetched no resource), that its script ran and knows every recorded frame, that
seeking by the API and by the slider draws the frame asked for with exactly the recorded number of
landmarks, landmark hypotheses, particles, rays of each decision and beam end points (and for the
grid run the latest picture of the occupancy grid), that the drawn pixels are
there (ray and ellipse colours on the map, a curve in each time panel), that Play advances the
frames and Pause stops them, and that zoom changes the view. The map fills
the window beside the side panel, at the screen's pixel ratio, and follows a new window size and
pixel ratio; its grid and scale bar are in round metres and follow zoom; the page says whether the
pose error is aligned (a recording marked aligned, rewritten by `slamkit replay`, says so too).

    replay_browser_test.py SLAMKIT WORKDIR                      the test (ctest runs this)
    replay_browser_test.py --screenshot OUT.png PAGE.html FRACTION
                                                                a picture of PAGE at FRACTION of the run
"""
import base64
import json
import math
import os
import shutil
import socket
import subprocess
import sys
import tempfile
import time
import urllib.error
import urllib.request

CHROMIUM = os.environ.get("CHROMIUM", "/usr/bin/chromium")
CHROMEDRIVER = os.environ.get("CHROMEDRIVER", "/usr/bin/chromedriver")
DECISIONS = ["update", "new", "discard", "wrong", "pending"]


class Browser:
    """One headless Chromium session behind its own chromedriver."""

    def __init__(self):
        with socket.socket() as s:
            s.bind(("127.0.0.1", 0))
            self.port = s.getsockname()[1]
        self.driver = subprocess.Popen([CHROMEDRIVER, f"--port={self.port}"], stdout=subprocess.DEVNULL,
                                       stderr=subprocess.DEVNULL)
        self.profile = tempfile.mkdtemp(prefix="slamkit_chromium_")
        self._wait_until(lambda: self._request("GET", "/status")["value"]["ready"], "chromedriver to start")
        args = ["--headless", "--no-sandbox", "--disable-gpu", "--disable-quic", "--no-first-run",
                "--disable-background-networking", "--disable-component-update", "--disable-sync",
                "--disable-dev-shm-usage", "--window-size=1260,860", f"--user-data-dir={self.profile}"]
        caps = {"capabilities": {"alwaysMatch": {"browserName": "chrome",
                                                 "goog:chromeOptions": {"binary": CHROMIUM, "args": args}}}}
        self.session = self._request("POST", "/session", caps)["value"]["sessionId"]

    def _request(self, method, path, body=None):
        data = None if body is None else json.dumps(body).encode()
        request = urllib.request.Request(f"http://127.0.0.1:{self.port}{path}", data=data, method=method,
                                         headers={"Content-Type": "application/json"})
        try:
            with urllib.request.urlopen(request, timeout=60) as response:
                return json.loads(response.read())
        except urllib.error.HTTPError as e:
            raise AssertionError(f"WebDriver {method} {path}: {e.read().decode()[:500]}") from None

    @staticmethod
    def _wait_until(condition, what, limit_s=30.0):
        deadline = time.monotonic() + limit_s
        while True:
            try:
                if condition():
                    return
            except (OSError, urllib.error.URLError):
                pass
            if time.monotonic() > deadline:
                raise AssertionError(f"gave up waiting for {what}")
            time.sleep(0.05)

    def command(self, method, path, body=None):
        return self._request(method, f"/session/{self.session}{path}", body)["value"]

    def open(self, page):
        self.command("POST", "/url", {"url": "file://" + os.path.abspath(page)})

    def js(self, script, *args):
        return self.command("POST", "/execute/sync", {"script": script, "args": list(args)})

    def click(self, css):
        element = self.command("POST", "/element", {"using": "css selector", "value": css})
        element_id = next(iter(element.values()))
        self.command("POST", f"/element/{element_id}/click", {})

    def cdp(self, command, params):
        """A Chrome DevTools Protocol command, through chromedriver."""
        return self.command("POST", "/goog/cdp/execute", {"cmd": command, "params": params})

    def screenshot(self, path):
        with open(path, "wb") as out:
            out.write(base64.b64decode(self.command("GET", "/screenshot")))

    def close(self):
        try:
            self._request("DELETE", f"/session/{self.session}")
        finally:
            self.driver.terminate()
            self.driver.wait(timeout=30)
            shutil.rmtree(self.profile, ignore_errors=True)


# Pixels of the map canvas near a colour (antialiased edges blend with white), and pixels of a canvas
# that are not white.
COUNT_NEAR = """
const [id, r, g, b] = arguments;
const c = document.getElementById(id);
const px = c.getContext('2d').getImageData(0, 0, c.width, c.height).data;
let n = 0;
for (let i = 0; i < px.length; i += 4)
  if (Math.abs(px[i] - r) + Math.abs(px[i + 1] - g) + Math.abs(px[i + 2] - b) < 40) n++;
return n;"""
COUNT_INK = """
const c = document.getElementById(arguments[0]);
const px = c.getContext('2d').getImageData(0, 0, c.width, c.height).data;
let n = 0;
for (let i = 0; i < px.length; i += 4) if (px[i] + px[i + 1] + px[i + 2] < 600) n++;
return n;"""
RAY_RGB = {"update": (22, 163, 74), "new": (37, 99, 235), "wrong": (220, 38, 38)}


def expected_counts(frame):
    rays = {name: 0 for name in DECISIONS}
    for code in frame["rays"][2::3]:
        rays[DECISIONS[int(code)]] += 1
    for code in frame.get("rings", [])[3::4]:
        rays[DECISIONS[int(code)]] += 1
    return {"landmarks": len(frame["landmarks"]) // 6, "hypotheses": len(frame.get("hypotheses", [])) // 7,
            "particles": len(frame.get("particles", [])) // 2, "rays": rays,
            "beamEnds": len(frame.get("beam_ends", [])) // 2}


def check(condition, message):
    if not condition:
        raise AssertionError(message)


def is_round(metres):
    """1, 2 or 5 times a power of ten."""
    mantissa = metres / 10 ** math.floor(math.log10(metres) + 1e-9)
    return any(abs(mantissa - m) < 1e-6 for m in (1, 2, 5))


def check_grid_and_scale(browser, page):
    """The grid's lines and the scale bar are round metres at the current zoom, inside the view."""
    drawn, view = browser.js("return window.replay.drawn"), browser.js("return window.replay.view")
    grid, bar, scale = drawn["grid"], drawn["scaleBar"], view["scale"]
    check(is_round(grid["step"]) and grid["step"] * scale >= 90 - 1e-6,
          f"{page}: grid step {grid['step']} m at {scale} px/m")
    left, right = view["cx"] - view["width"] / 2 / scale, view["cx"] + view["width"] / 2 / scale
    bottom, top = view["cy"] - view["height"] / 2 / scale, view["cy"] + view["height"] / 2 / scale
    for values, lo, hi in ((grid["x"], left, right), (grid["y"], bottom, top)):
        check(len(values) >= 2, f"{page}: fewer than two grid lines across the map")
        check(all(lo - 1e-9 <= v <= hi + 1e-9 for v in values), f"{page}: grid lines outside the view")
        steps = [b - a for a, b in zip(values, values[1:])]
        check(all(abs(d - grid["step"]) < 1e-6 * grid["step"] for d in steps), f"{page}: uneven grid {values}")
    check(is_round(bar["metres"]) and abs(bar["pixels"] - bar["metres"] * scale) < 1e-6 * bar["pixels"]
          and 80 - 1e-6 <= bar["pixels"] < 200, f"{page}: scale bar {bar} at {scale} px/m")
    check(browser.js(COUNT_NEAR, "map", 17, 24, 39) > 0, f"{page}: no scale bar pixels on the map")
    check(browser.js(COUNT_NEAR, "map", 75, 85, 99) > 0, f"{page}: no axis label pixels on the map")
    return grid, bar


def check_layout(browser, page):
    """The map takes the window's width beside the side panel and its height below the controls, with
    one canvas pixel per screen pixel."""
    size = browser.js("return window.replay.drawn.size")
    box = browser.js("const r = document.getElementById('map').getBoundingClientRect();"
                     "return [r.right, r.bottom, document.querySelector('aside').getBoundingClientRect().left,"
                     "window.innerHeight, window.devicePixelRatio]")
    right, bottom, aside_left, window_height, ratio = box
    check(0 <= aside_left - right <= 14 and 0 <= window_height - bottom <= 14,
          f"{page}: the map does not fill the window (right {right}, side panel at {aside_left}; bottom {bottom} "
          f"of {window_height})")
    check(size["ratio"] == ratio and size["pixelWidth"] == round(size["w"] * ratio)
          and size["pixelHeight"] == round(size["h"] * ratio), f"{page}: canvas pixels {size} at ratio {ratio}")
    return size


def check_page(browser, page, recording, particles_expected):
    frames = recording["frames"]
    check(len(frames) > 10, f"{page}: expected a recording of more than 10 frames, found {len(frames)}")
    browser.open(page)
    check(browser.js("return typeof window.replay === 'object'"), f"{page}: the replay script did not run")
    check(browser.js("return window.replay.data.frames.length") == len(frames),
          f"{page}: the page does not hold every recorded frame")
    external = browser.js("return document.querySelectorAll('script[src], link[href], img[src], iframe').length")
    fetched = browser.js("return performance.getEntriesByType('resource').length")
    check(external == 0 and fetched == 0, f"{page}: not self-contained ({external} external elements, "
                                          f"{fetched} resources fetched)")

    # Seek by the API and by the slider; each time the map draws exactly the recorded frame.
    for k in sorted({0, len(frames) // 3, len(frames) // 2, len(frames) - 1}):
        browser.js("window.replay.seek(arguments[0])", k)
        drawn = browser.js("return window.replay.drawn")
        check(drawn["frame"] == k, f"{page}: seek({k}) drew frame {drawn['frame']}")
        want = expected_counts(frames[k])
        got = {"landmarks": drawn["landmarks"], "hypotheses": drawn["hypotheses"], "particles": drawn["particles"],
               "rays": drawn["rays"], "beamEnds": drawn["beamEnds"]}
        check(got == want, f"{page}: frame {k} drew {got}, the recording holds {want}")
        check(f"frame {k + 1}/{len(frames)}" in browser.js("return document.getElementById('label').textContent"),
              f"{page}: the label does not name frame {k + 1}")
    middle = len(frames) // 2
    browser.js("const s = document.getElementById('time'); s.value = String(arguments[0]);"
               "s.dispatchEvent(new Event('input'));", middle)
    check(browser.js("return window.replay.frame") == middle, f"{page}: the slider did not seek to {middle}")

    # What is on the canvases: rays in the colour of their decision, map ellipses, the time panels' curves.
    counts = expected_counts(frames[middle])
    for name, rgb in RAY_RGB.items():
        if counts["rays"][name] > 0:
            check(browser.js(COUNT_NEAR, "map", *rgb) > 0, f"{page}: no {name} ray pixels on the map")
    if counts["landmarks"]:
        check(browser.js(COUNT_NEAR, "map", 30, 58, 138) > 0, f"{page}: no landmark pixels on the map")
    if counts["hypotheses"]:
        check(browser.js(COUNT_NEAR, "map", 217, 119, 6) > 0, f"{page}: no hypothesis pixels on the map")
    if particles_expected:
        check(counts["particles"] > 0, f"{page}: the recording has no particles")
        check(browser.js(COUNT_NEAR, "map", 147, 51, 234) > 0, f"{page}: no particle pixels on the map")
    grid_run = any("beam_ends" in f for f in frames)
    if grid_run:
        # The occupancy grid: the latest picture at or before the frame, once its image has loaded,
        # with its black walls; the beams' end points on them.
        pictured = max(k for k in range(middle + 1) if "grid" in frames[k])
        Browser._wait_until(lambda: browser.js("return window.replay.drawn.occupancy") is not None,
                            f"{page}: the occupancy grid to be drawn")
        occupancy = browser.js("return window.replay.drawn.occupancy")
        check(occupancy["frame"] == pictured, f"{page}: frame {middle} shows the grid of frame "
                                              f"{occupancy['frame']}, not of {pictured}")
        check(browser.js(COUNT_NEAR, "map", 0, 0, 0) > 200, f"{page}: no wall pixels on the map")
        check(browser.js(COUNT_NEAR, "map", 8, 145, 178) > 0, f"{page}: no beam end pixels on the map")
    check(browser.js(COUNT_INK, "error") > 500, f"{page}: the pose-error panel is empty")
    if not grid_run:
        check(browser.js(COUNT_INK, "std") > 500, f"{page}: the landmark-std panel is empty")

    # Play advances the frames, Pause stops them.
    browser.js("window.replay.seek(0)")
    browser.click("#play")
    Browser._wait_until(lambda: browser.js("return window.replay.frame") > 3, f"{page}: Play to advance")
    browser.click("#play")
    check(not browser.js("return window.replay.playing"), f"{page}: Pause did not stop playback")
    stopped = browser.js("return window.replay.frame")
    time.sleep(0.3)
    check(browser.js("return window.replay.frame") == stopped, f"{page}: frames moved after Pause")

    # The pose error says how it is taken: the truth of a simulated run shares the map's frame.
    note = browser.js("return document.getElementById('error-note').textContent")
    check(not browser.js("return window.replay.errorAligned") and "unaligned" in note,
          f"{page}: the page does not say that the pose error is unaligned: {note!r}")

    check_layout(browser, page)
    grid, bar = check_grid_and_scale(browser, page)
    scale = browser.js("return window.replay.scale")
    browser.js("window.replay.zoom(2)")
    check(abs(browser.js("return window.replay.scale") - 2 * scale) < 1e-9 * scale, f"{page}: zoom did not apply")
    browser.js("window.replay.zoom(4)")
    zoomed_grid, zoomed_bar = check_grid_and_scale(browser, page)
    check(zoomed_grid["step"] < grid["step"] and zoomed_bar["metres"] < bar["metres"],
          f"{page}: grid and scale bar did not follow the zoom ({grid['step']} -> {zoomed_grid['step']} m, "
          f"{bar['metres']} -> {zoomed_bar['metres']} m)")


def check_resizing(browser, page):
    """A smaller window on a screen of twice the pixel density: the map follows, sharp."""
    browser.open(page)
    before = check_layout(browser, page)
    scale = browser.js("return window.replay.scale")
    browser.cdp("Emulation.setDeviceMetricsOverride", {"width": 1000, "height": 700, "deviceScaleFactor": 2,
                                                       "mobile": False})
    try:
        Browser._wait_until(lambda: browser.js("return window.replay.drawn.size")["ratio"] == 2
                            and browser.js("return window.replay.drawn.size")["w"] < before["w"],
                            f"{page}: the map to follow the new window")
        after = check_layout(browser, page)
        check(after["pixelWidth"] == 2 * after["w"], f"{page}: {after} is not drawn at twice the density")
        check(browser.js("return window.replay.scale") < scale, f"{page}: the fitted view was not fitted again")
        check(browser.js(COUNT_INK, "map") > 1000, f"{page}: nothing drawn after the resize")
        check_grid_and_scale(browser, page)
    finally:
        browser.cdp("Emulation.clearDeviceMetricsOverride", {})


def check_aligned_note(browser, cli, work):
    """A recording whose error was taken after alignment (a GPS truth) says so."""
    folder = os.path.join(work, "aligned")
    shutil.copytree(os.path.join(work, "ekf"), folder)
    with open(os.path.join(folder, "replay.json")) as f:
        recording = json.load(f)
    recording["meta"]["error_aligned"] = True
    with open(os.path.join(folder, "replay.json"), "w") as f:
        json.dump(recording, f)
    run(cli, work, "replay", folder)
    browser.open(os.path.join(folder, "replay.html"))
    note = browser.js("return document.getElementById('error-note').textContent")
    check(browser.js("return window.replay.errorAligned") and "SE(2) alignment" in note and "unaligned" not in note,
          f"aligned recording: the page does not say the error is aligned: {note!r}")


def run(cli, work, *args):
    result = subprocess.run([cli, *args], cwd=work, capture_output=True, text=True)
    if result.returncode != 0:
        raise AssertionError(f"slamkit {' '.join(args)} failed ({result.returncode}): {result.stderr}")


def main(argv):
    if len(argv) == 5 and argv[1] == "--screenshot":
        browser = Browser()
        try:
            browser.open(argv[3])
            browser.js("window.replay.seek(Math.round(arguments[0] * (window.replay.data.frames.length - 1)))",
                       float(argv[4]))
            browser.screenshot(argv[2])
        finally:
            browser.close()
        return 0
    if len(argv) != 3:
        print(__doc__, file=sys.stderr)
        return 2
    cli, work = os.path.abspath(argv[1]), argv[2]
    shutil.rmtree(work, ignore_errors=True)
    os.makedirs(work)
    run(cli, work, "simulate", "--seed", "1", "--out", "sim")
    run(cli, work, "run", "--filter", "ekf", "--data", "sim:sim", "--out", "ekf", "--replay", "--quiet")
    run(cli, work, "run", "--filter", "fastslam2", "--assoc", "nn", "--particles", "30", "--data", "sim:sim",
        "--out", "fastslam", "--replay", "--quiet")
    # A radio's ranges: each drawn as a circle, and the ring start's hypotheses of the beacons waiting.
    run(cli, work, "simulate", "--seed", "1", "--sensor", "range-only", "--loops", "1", "--out", "radio")
    run(cli, work, "run", "--filter", "ekf", "--ekf-variant", "fej", "--landmark-init", "ring", "--data",
        "sim:radio", "--out", "ring", "--replay", "--quiet")
    run(cli, work, "simulate", "--building", "office", "--seed", "1", "--loops", "1", "--out", "building")
    run(cli, work, "run", "--filter", "grid-fastslam", "--particles", "5", "--data", "carmen:building/office.log",
        "--out", "grid", "--replay", "--quiet")
    browser = Browser()
    try:
        for folder, particles in (("ekf", False), ("fastslam", True), ("ring", False), ("grid", True)):
            with open(os.path.join(work, folder, "replay.json")) as f:
                recording = json.load(f)
            if folder == "ring":
                check(any(f.get("hypotheses") for f in recording["frames"]), "ring: no frame holds hypotheses")
            check_page(browser, os.path.join(work, folder, "replay.html"), recording, particles)
            print(f"{folder}: {len(recording['frames'])} frames checked")
        check_resizing(browser, os.path.join(work, "ekf", "replay.html"))
        check_aligned_note(browser, cli, work)
        print("resizing, pixel ratio and the aligned note checked")
    finally:
        browser.close()
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv))
