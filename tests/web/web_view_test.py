#!/usr/bin/python3
"""The web view in a real browser: Debian's chromium, headless, driven by Debian's
python3-selenium through chromium-driver (ctest web_view_browser_test, docs/web-view.md).

cairn-base serves the view; two fake robots drive circles in a walled 8 x 6 m room
(cairn-test-room-robots), on a loopback DDS domain of their own. Checked: the page, the
state, a command and the socket upgrade are refused without the token (401) and work with
it; the canvas shows the room's walls black at the pixels where the known room and the
configured map geometry put them (computed here, not by the page), clear inside and
unknown outside; robot 1's marker moves; an unknown command is refused; a click on the
map sends a visit request that the base accepts, assigns (a goto task) and logs. A
screenshot is kept. Every wait is a bounded poll for a condition.

Runs with Debian's /usr/bin/python3 (python3-selenium lives in its dist-packages):
  /usr/bin/python3 web_view_test.py --base BIN --robots BIN --config TOML --dds LOOPBACK_XML --out DIR
"""
import argparse
import base64
import hashlib
import json
import math
import os
import re
import shutil
import signal
import socket
import subprocess
import sys
import tempfile
import threading
import time
import urllib.error
import urllib.request

CHROMIUM = "/usr/bin/chromium"
CHROMEDRIVER = "/usr/bin/chromedriver"
TOKEN = "test-token-0123456789"  # tests/web/base-web.toml
# The known world (tests/support/room_robots_main.cpp) and map (tests/web/base-web.toml).
ROOM_HALF_W, ROOM_HALF_H = 4.0, 3.0  # walls at x = +-4, y = +-3 m
MAP_ORIGIN, MAP_SIZE, MAP_RESOLUTION = (-6.0, -5.0), (12.0, 10.0), 0.15  # 0.15: the mapper's default
CANVAS_W, CANVAS_H = 800, 640  # basestation/web/page/index.html
WHOLE_TEST_S = 50.0

t0 = time.monotonic()
children = []
failures = 0
driver = None


def elapsed():
    return f"{time.monotonic() - t0:5.1f} s"


def check(ok, what):
    global failures
    print(f"{'ok  ' if ok else 'FAIL'} [{elapsed()}] {what}", flush=True)
    if not ok:
        failures += 1
    return ok


def stop_children(sig=signal.SIGTERM, wait_s=10.0):
    for c in children:
        if c.poll() is None:
            c.send_signal(sig)
    for c in children:
        try:
            c.wait(timeout=wait_s)
        except subprocess.TimeoutExpired:
            c.kill()
            c.wait()


def quit_browser():
    global driver
    if driver is not None:
        d, driver = driver, None
        # quit() can hang on a wedged chromedriver: bounded, in a thread of its own.
        t = threading.Thread(target=d.quit, daemon=True)
        t.start()
        t.join(10)


def fatal(what):
    print(f"FAIL [{elapsed()}] {what}", flush=True)
    quit_browser()
    stop_children(signal.SIGKILL, 5)
    print("web view: failed", flush=True)
    os._exit(1)


def poll(fn, timeout_s, interval_s=0.1):
    """fn() until it is truthy (returned) or timeout_s passes (None). A bounded wait."""
    end = time.monotonic() + timeout_s
    while True:
        v = fn()
        if v:
            return v
        if time.monotonic() >= end:
            return None
        time.sleep(interval_s)


def read(path):
    with open(path, "r", errors="replace") as f:
        return f.read()


# --- Plain HTTP and a hand-made WebSocket upgrade, no proxy (everything is on loopback) ---

http = urllib.request.build_opener(urllib.request.ProxyHandler({}))


def http_status(port, target, method="GET", body=None, headers=None):
    req = urllib.request.Request(f"http://127.0.0.1:{port}{target}", data=body, method=method, headers=headers or {})
    try:
        with http.open(req, timeout=10) as r:
            r.read()
            return r.status
    except urllib.error.HTTPError as e:
        return e.code


WS_KEY = "dGhlIHNhbXBsZSBub25jZQ=="


def upgrade(port, target):
    """A WebSocket upgrade by hand: (status, headers) of the server's answer."""
    with socket.create_connection(("127.0.0.1", port), timeout=10) as s:
        s.sendall((f"GET {target} HTTP/1.1\r\nHost: 127.0.0.1:{port}\r\nConnection: Upgrade\r\nUpgrade: websocket\r\n"
                   f"Sec-WebSocket-Version: 13\r\nSec-WebSocket-Key: {WS_KEY}\r\n\r\n").encode())
        data = b""
        while b"\r\n\r\n" not in data:
            chunk = s.recv(4096)
            if not chunk:
                break
            data += chunk
    head = data.split(b"\r\n\r\n")[0].decode("latin-1").split("\r\n")
    m = re.match(r"HTTP/1\.1 (\d{3})", head[0]) if head else None
    headers = {k.strip().lower(): v.strip() for k, _, v in (h.partition(":") for h in head[1:])}
    return (int(m.group(1)) if m else None), headers


# --- The expected canvas, computed from the known room and map geometry ---

def map_fit(m):
    """The page's documented drawing: the map fills the canvas keeping its aspect, centred."""
    scale = min(CANVAS_W / m["width"], CANVAS_H / m["height"])
    return scale, (CANVAS_W - m["width"] * scale) / 2, (CANVAS_H - m["height"] * scale) / 2


def cell_pixel(m, i, j):
    """Canvas pixel at the centre of map cell (i, j) (row j counts up from the map's bottom)."""
    scale, ox, oy = map_fit(m)
    return round(ox + (i + 0.5) * scale), round(oy + (m["height"] - 1 - j + 0.5) * scale)


def cell_of(m, x, y):
    return math.floor((x - m["origin_x"]) / m["resolution"]), math.floor((y - m["origin_y"]) / m["resolution"])


def world_pixel(m, x, y):
    scale, ox, oy = map_fit(m)
    return ox + (x - m["origin_x"]) / m["resolution"] * scale, oy + (m["height"] - (y - m["origin_y"]) / m["resolution"]) * scale


def expected_room(m):
    """Named canvas pixels and what each must be: the wall cells black; two cells inside
    clear (white); two cells outside unknown (grey). A map drawn two cells off, blank, or
    of another room fails at least one of them."""
    points = []  # (what, (px, py), kind)
    for y in (-2.5, -1.5, 0.5, 2.5):
        for sx in (1, -1):
            i, j = cell_of(m, sx * ROOM_HALF_W, y)
            points.append((f"wall x={sx * ROOM_HALF_W:+.0f} at y={y}", cell_pixel(m, i, j), "wall"))
            points.append((f"inside x={sx * ROOM_HALF_W:+.0f} at y={y}", cell_pixel(m, i - 2 * sx, j), "clear"))
            points.append((f"outside x={sx * ROOM_HALF_W:+.0f} at y={y}", cell_pixel(m, i + 2 * sx, j), "unknown"))
    for x in (-3.5, -2.5, 2.5, 3.5):
        for sy in (1, -1):
            i, j = cell_of(m, x, sy * ROOM_HALF_H)
            points.append((f"wall y={sy * ROOM_HALF_H:+.0f} at x={x}", cell_pixel(m, i, j), "wall"))
            points.append((f"inside y={sy * ROOM_HALF_H:+.0f} at x={x}", cell_pixel(m, i, j - 2 * sy), "clear"))
            points.append((f"outside y={sy * ROOM_HALF_H:+.0f} at x={x}", cell_pixel(m, i, j + 2 * sy), "unknown"))
    # Far from the room: unknown.
    points.append(("unknown at (5.5, 4.5)", cell_pixel(m, *cell_of(m, 5.5, 4.5)), "unknown"))
    points.append(("unknown at (-5.5, -4.5)", cell_pixel(m, *cell_of(m, -5.5, -4.5)), "unknown"))
    return points


def pixel_kind(rgb):
    r, g, b = rgb[:3]
    if max(r, g, b) < 40:
        return "wall"
    if min(r, g, b) > 240:
        return "clear"
    if 170 <= min(r, g, b) and max(r, g, b) <= 210 and max(r, g, b) - min(r, g, b) < 10:
        return "unknown"  # the PNG's 190 grey
    return "other"


READ_PIXELS = """
const ctx = document.getElementById("map").getContext("2d");
return arguments[0].map((p) => Array.from(ctx.getImageData(p[0], p[1], 1, 1).data.slice(0, 3)));
"""

# Robot 1's disc (red) off its heading line: where it is drawn and the colour there.
MARKER = """
const v = window.cairnView;
const r = v.state && v.state.robots.find((x) => x.id === 1 && x.pose);
if (!r || !v.map) return null;
const c = v.worldToCanvas(r.pose.x, r.pose.y);
const px = Math.round(c[0] - 3 * Math.cos(r.pose.theta)), py = Math.round(c[1] + 3 * Math.sin(r.pose.theta));
const d = document.getElementById("map").getContext("2d").getImageData(px, py, 1, 1).data;
return {x: c[0], y: c[1], wx: r.pose.x, wy: r.pose.y, rgb: Array.from(d.slice(0, 3))};
"""


def main():
    global driver
    ap = argparse.ArgumentParser()
    for a in ("base", "robots", "config", "dds", "out"):
        ap.add_argument("--" + a, required=True)
    args = ap.parse_args()
    out = os.path.abspath(args.out)
    os.makedirs(out, exist_ok=True)

    # A watchdog: whatever hangs, the test ends failed with its children, before ctest's TIMEOUT.
    threading.Timer(WHOLE_TEST_S, lambda: fatal(f"the whole test took over {WHOLE_TEST_S:.0f} s")).start()

    # What it needs: a missing one fails the test, naming the fix (never a skip).
    try:
        from selenium import webdriver
        from selenium.common.exceptions import WebDriverException
        from selenium.webdriver.chrome.service import Service
        from selenium.webdriver.common import utils as selenium_utils
        from selenium.webdriver.common.action_chains import ActionBuilder
        from selenium.webdriver.common.by import By
        from selenium.webdriver.support.ui import Select
    except ImportError as e:
        fatal(f"python3-selenium is missing for {sys.executable} ({e}): scripts/setup-deps.sh installs it; "
              "run with Debian's /usr/bin/python3")
    for path, pkg in ((CHROMIUM, "chromium"), (CHROMEDRIVER, "chromium-driver")):
        if not os.access(path, os.X_OK):
            fatal(f"{path} is missing: scripts/setup-deps.sh installs Debian's {pkg}")

    # Loopback only: no proxy for our requests, chromedriver's or chromium's.
    for k in ("http_proxy", "https_proxy", "HTTP_PROXY", "HTTPS_PROXY", "all_proxy", "ALL_PROXY"):
        os.environ.pop(k, None)

    domain = 200 + os.getpid() % 30  # outside the 100..199 the process tests draw from
    run_dir = tempfile.mkdtemp(prefix="run-", dir=out)
    config = os.path.join(run_dir, "base.toml")
    with open(config, "w") as f:
        f.write(read(args.config).replace("@DOMAIN@", str(domain)).replace("@DIR@", run_dir))
    env = dict(os.environ, CYCLONEDDS_URI=f"file://{os.path.abspath(args.dds)}")
    base_log = os.path.join(out, "base.log")
    with open(os.path.join(out, "robots.log"), "w") as log:
        children.append(subprocess.Popen([args.robots, "--domain", str(domain), "--duration", "60"],
                                         stdout=log, stderr=subprocess.STDOUT, env=env))
    with open(base_log, "w") as log:  # stdout and stderr: the log lines go to either
        base = subprocess.Popen([args.base, "-c", config, "--duration", "60"], stdout=log, stderr=subprocess.STDOUT, env=env)
    children.append(base)
    listening = poll(lambda: re.search(r"web view listening on 127\.0\.0\.1 port (\d+)", read(base_log)) or base.poll() is not None, 10)
    if not isinstance(listening, re.Match):
        fatal(f"cairn-base printed no web view address within 10 s (exit {base.poll()}): {base_log}")
    port = int(listening.group(1))
    url = f"http://127.0.0.1:{port}"
    print(f"[{elapsed()}] cairn-base on DDS domain {domain}, web view on port {port}", flush=True)

    # Access: nothing without the token, not even a command.
    check(http_status(port, "/") == 401, "the page without the token: 401")
    check(http_status(port, "/?token=wrong-token-0123456789") == 401, "the page with a wrong token: 401")
    check(http_status(port, "/api/state") == 401, "the state without the token: 401")
    check(http_status(port, "/api/command", "POST", json.dumps({"cmd": "visit", "robot": 1, "x": 0, "y": 0}).encode()) == 401,
          "a command without the token: 401")
    check(upgrade(port, "/ws")[0] == 401, "the WebSocket upgrade without the token: 401")
    check(upgrade(port, "/ws?token=wrong-token-0123456789")[0] == 401, "the WebSocket upgrade with a wrong token: 401")
    status, headers = upgrade(port, f"/ws?token={TOKEN}")
    accept = base64.b64encode(hashlib.sha1((WS_KEY + "258EAFA5-E914-47DA-95CA-C5AB0DC85B11").encode()).digest()).decode()
    check(status == 101 and headers.get("sec-websocket-accept") == accept,
          f"the WebSocket upgrade with the token: 101, Sec-WebSocket-Accept right ({status})")
    check(http_status(port, "/api/state", headers={"X-Cairn-Token": TOKEN}) == 200, "the state with the token as a header: 200")
    check(http_status(port, "/api/state", headers={"Authorization": f"Bearer {TOKEN}"}) == 200, "the state with a bearer token: 200")

    options = webdriver.ChromeOptions()
    options.binary_location = CHROMIUM
    profile = tempfile.mkdtemp(prefix="cairn-chromium-")  # a fresh user-data dir, removed at the end
    for a in ("--headless=new",
              "--no-sandbox",  # chromium refuses to run as root with its sandbox (CI runs as root)
              "--disable-gpu", "--disable-dev-shm-usage",  # containers: no GPU, a small /dev/shm
              f"--user-data-dir={profile}", "--window-size=1240,900", "--no-proxy-server",
              "--no-first-run", "--no-default-browser-check", "--disable-extensions", "--disable-sync",
              "--disable-background-networking", "--disable-component-update",  # no calls home from a fresh machine
              "--disable-background-timer-throttling", "--disable-renderer-backgrounding",
              # chromedriver talks to chromium over a pipe: its TCP DevTools connection goes to
              # "localhost", which a fresh root without /etc/hosts cannot resolve
              "--remote-debugging-pipe"):
        options.add_argument(a)
    options.set_capability("goog:loggingPrefs", {"browser": "ALL"})
    t_browser = time.monotonic()
    # selenium's Service polls and addresses chromedriver as "localhost", which a fresh Debian
    # root without /etc/hosts cannot resolve (the first fresh-machine run failed so: "Can not
    # connect to the Service"): this one uses 127.0.0.1.
    class LoopbackService(Service):
        @property
        def service_url(self):
            return f"http://127.0.0.1:{self.port}"

        def is_connectable(self):
            return selenium_utils.is_connectable(self.port, "127.0.0.1")
    try:
        driver = webdriver.Chrome(service=LoopbackService(executable_path=CHROMEDRIVER, log_path=os.path.join(out, "chromedriver.log")),
                                  options=options)
    except WebDriverException as e:
        fatal(f"chromium did not start under chromedriver: {e.msg} (log: {out}/chromedriver.log)")
    print(f"[{elapsed()}] chromium {driver.capabilities.get('browserVersion')} started in {time.monotonic() - t_browser:.1f} s", flush=True)
    # The viewport exactly 1240 x 720 CSS px at scale 1 (--window-size counts the window, not the page).
    driver.execute_cdp_cmd("Emulation.setDeviceMetricsOverride", {"width": 1240, "height": 720, "deviceScaleFactor": 1, "mobile": False})
    driver.set_page_load_timeout(15)
    driver.set_script_timeout(10)
    nav_status = "const e = performance.getEntriesByType('navigation')[0]; return e ? e.responseStatus : null;"
    try:
        driver.get(url + "/")
        check(driver.execute_script(nav_status) == 401 and not driver.find_elements(By.ID, "map"),
              "chromium: the page without the token is refused (401, no map)")
        driver.get(f"{url}/?token={TOKEN}")
        check(driver.execute_script(nav_status) == 200 and driver.title == "Cairn base: live view",
              f"chromium: the page with the token loads (200, title {driver.title!r})")
        linked = poll(lambda: driver.find_element(By.ID, "link").text == "live", 10)
        check(bool(linked), "chromium: the page's socket is live")

        # The map message matches the configured map: the geometry the expected pixels use.
        m = poll(lambda: driver.execute_script("const v = window.cairnView; return v.map && v.image ? "
                                               "{origin_x: v.map.origin_x, origin_y: v.map.origin_y, resolution: v.map.resolution, "
                                               "width: v.map.width, height: v.map.height} : null;"), 10)
        if not m:
            fatal("no map reached the page within 10 s")
        check(abs(m["origin_x"] - MAP_ORIGIN[0]) < 1e-6 and abs(m["origin_y"] - MAP_ORIGIN[1]) < 1e-6
              and abs(m["resolution"] - MAP_RESOLUTION) < 1e-6 and abs(m["width"] * m["resolution"] - MAP_SIZE[0]) <= m["resolution"]
              and abs(m["height"] * m["resolution"] - MAP_SIZE[1]) <= m["resolution"], f"the map is the configured one: {m}")
        # The page's transform agrees with the one computed here (robots and clicks use it).
        page_px = driver.execute_script("return [window.cairnView.worldToCanvas(4, 3), window.cairnView.worldToCanvas(-4, -3)];")
        mine = [world_pixel(m, 4, 3), world_pixel(m, -4, -3)]
        check(all(abs(a - b) < 0.5 for p, q in zip(page_px, mine) for a, b in zip(p, q)),
              f"the page puts the room's corners where expected: {page_px} vs {mine}")

        # The room on the canvas: every expected pixel of its kind once the scans have drawn it.
        points = expected_room(m)
        last = {}

        def room_drawn():
            rgbs = driver.execute_script(READ_PIXELS, [p for _, p, _ in points])
            last["bad"] = [(what, p, want, rgb) for (what, p, want), rgb in zip(points, rgbs) if pixel_kind(rgb) != want]
            return not last["bad"]
        drawn = poll(room_drawn, 15)
        walls = sum(1 for _, _, k in points if k == "wall")
        check(bool(drawn), f"the canvas shows the room: {walls} wall cells black, {len(points) - walls} cells beside them clear "
              f"inside and unknown outside, at the pixels computed from the room and the map"
              + ("" if drawn else f"; wrong: {last['bad'][:6]}"))
        # The same pixels with the map shifted by two cells would not pass (the check can fail).
        shifted = [(what, (p[0] + round(2 * map_fit(m)[0]), p[1]), want) for what, p, want in points]
        rgbs = driver.execute_script(READ_PIXELS, [p for _, p, _ in shifted])
        check(sum(pixel_kind(c) != want for (_, _, want), c in zip(shifted, rgbs)) >= 8,
              "control: the same expectations two cells to the right fail")

        # A robot marker moves: robot 1's red disc at one place, later at another.
        def red(mk):
            return mk is not None and mk["rgb"][0] > 180 and mk["rgb"][1] < 80 and mk["rgb"][2] < 80
        first = poll(lambda: driver.execute_script(MARKER), 5)
        check(red(first), f"robot 1's marker drawn in red: {first}")
        second = poll(lambda: (lambda mk: mk if mk and math.hypot(mk["x"] - first["x"], mk["y"] - first["y"]) > 10 else None)(
            driver.execute_script(MARKER)), 10) if first else None
        check(red(second), f"robot 1's marker moved over 10 px, drawn in red: {first and (round(first['x']), round(first['y']))} -> "
              f"{second and (round(second['x']), round(second['y']))}")
        # Its pose is on the fake robot's circle (centre (-1.5, 1), radius 1): the marker is the robot, not noise.
        check(second is not None and abs(math.hypot(second["wx"] + 1.5, second["wy"] - 1.0) - 1.0) < 0.1,
              f"robot 1 is on its 1 m circle about (-1.5, 1): ({second and round(second['wx'], 2)}, {second and round(second['wy'], 2)})")

        # A bad command over the page's socket: a clear error, not a crash.
        driver.execute_script("window.cairnView.lastReply = null; window.cairnView.socket.send(JSON.stringify({cmd: 'self-destruct'}));")
        bad = poll(lambda: driver.execute_script("return window.cairnView.lastReply;"), 5)
        check(bool(bad) and bad.get("ok") is False and "unknown command" in str(bad.get("error")), f"an unknown command is refused: {bad}")

        # The panel: robot 1's RT loop figures, as its status gives them.
        rt = poll(lambda: (lambda t: t if "10000 / 10100" in t else None)(driver.find_element(By.ID, "rt").text), 5)
        check(bool(rt), f"the RT loop table shows robot 1's period mean / p99: {rt!r}")

        # Exploration: robot 1's bid (one frontier, region [2, 1]-[3.5, 2.5]) gets it an explore task with
        # that region; the page draws the bid's circle and the region, and shows the stop button.
        explore_js = """
            const s = window.cairnView.state;
            const r = s && s.robots.find((x) => x.id === 1);
            return r && r.task && r.bid ? {task: r.task, bid: r.bid, exploration: s.exploration,
                                           button: document.getElementById('explore').textContent} : null;"""
        ex = poll(lambda: (lambda e: e if e and e["task"]["kind"] == "explore" else None)(driver.execute_script(explore_js)), 10)
        check(bool(ex) and ex["task"].get("igr") == [2.0, 1.0, 3.5, 2.5] and abs(ex["task"]["x"] - 2.5) < 1e-9
              and len(ex["bid"]["items"]) == 1 and ex["button"] == "stop exploration",
              f"robot 1's bid gave it an explore task with its region, and the page offers to stop: {ex}")
        # The region's dashed outline in robot 1's red crosses the map at its left edge's middle.
        igr_px = world_pixel(m, 2.0, 1.75)
        drawn = poll(lambda: any(red({"rgb": c}) for c in driver.execute_script(
            "const d = document.getElementById('map').getContext('2d').getImageData(arguments[0] - 1, arguments[1] - 6, 3, 13).data;"
            "const out = []; for (let k = 0; k < d.length; k += 4) out.push([d[k], d[k + 1], d[k + 2]]); return out;",
            round(igr_px[0]), round(igr_px[1]))), 5)
        check(bool(drawn), f"the task's region drawn in red at its left edge {tuple(round(v) for v in igr_px)}")
        driver.find_element(By.ID, "explore").click()
        stopped = poll(lambda: (lambda e: e if e and e["exploration"]["paused"] and e["task"]["kind"] == "idle"
                                and e["button"] == "start exploration" else None)(driver.execute_script(explore_js)), 5)
        check(bool(stopped), f"'stop exploration': the base stops it, robot 1 told idle: {stopped and stopped['task']}")
        check(bool(poll(lambda: "exploration stopped by the web view" in read(base_log), 5)), "the base logged the stop")
        driver.find_element(By.ID, "explore").click()
        resumed = poll(lambda: (lambda e: e if e and not e["exploration"]["paused"] and e["task"]["kind"] == "explore"
                                else None)(driver.execute_script(explore_js)), 5)
        check(bool(resumed), f"'start exploration': robot 1 explores again: {resumed and resumed['task']}")

        # Robot 2 starts latched: its row offers a reset; the click runs the base's reset exchange
        # (SafetyReset, confirmed by its status) and the robot drives again.
        button = poll(lambda: driver.find_elements(By.CSS_SELECTOR, 'button.reset[data-robot="2"]'), 5)
        check(bool(button) and not driver.find_elements(By.CSS_SELECTOR, 'button.reset[data-robot="1"]'),
              "robot 2 (latched) offers a reset, robot 1 (running) does not")
        if button:
            button[0].click()
        reset = poll(lambda: driver.execute_script("""
            const s = window.cairnView.state;
            const c = s.commands.find((x) => x.cmd === "reset" && x.robot === 2);
            const r = s.robots.find((x) => x.id === 2);
            return c && c.result.startsWith("done") && !r.reset_required ? c : null;"""), 10)
        check(bool(reset), f"the reset confirmed by robot 2's status: {reset}")
        check(bool(poll(lambda: "robot 2: reset by 'web view'" in read(os.path.join(out, "robots.log")), 5)),
              "robot 2 received the base's SafetyReset, from the web view")

        # Click: robot 1 chosen, the map clicked at a clear point; the base assigns the visit.
        visits_before = read(base_log).count("asked by web view")
        if not poll(lambda: driver.find_elements(By.CSS_SELECTOR, '#robot option[value="1"]'), 5):
            fatal("robot 1 never appeared in the page's robot list")
        Select(driver.find_element(By.ID, "robot")).select_by_value("1")
        target = (0.0, 2.2)
        rect = driver.execute_script("const r = document.getElementById('map'); const b = r.getBoundingClientRect(); "
                                     "return [b.left + r.clientLeft, b.top + r.clientTop, r.clientWidth, r.clientHeight];")
        cx, cy = world_pixel(m, *target)
        at = (round(rect[0] + cx * rect[2] / CANVAS_W), round(rect[1] + cy * rect[3] / CANVAS_H))
        inner = driver.execute_script("return [window.innerWidth, window.innerHeight];")
        check(0 <= at[0] < inner[0] and 0 <= at[1] < inner[1], f"the click's point {at} is in the {inner[0]} x {inner[1]} viewport")
        click = ActionBuilder(driver)
        click.pointer_action.move_to_location(*at)
        click.pointer_action.click()
        click.perform()
        print(f"[{elapsed()}] clicked the map at viewport {at} for ({target[0]}, {target[1]}) m", flush=True)
        done = poll(lambda: driver.execute_script("""
            const s = window.cairnView.state;
            const c = s.commands.find((x) => x.robot === 1);
            const r = s.robots.find((x) => x.id === 1);
            return c && r.task && r.task.kind === "goto" ? {command: c, task: r.task} : null;"""), 10)

        def near(a, b):
            return abs(a - b) <= 0.1  # two cells: the click lands on a pixel, not a point
        cmd = done and done["command"]
        check(bool(cmd) and cmd["result"] == "accepted" and near(cmd["x"], target[0]) and near(cmd["y"], target[1]),
              f"the click's visit request accepted by the base: {cmd}")
        task = done and done["task"]
        check(bool(task) and task["active"] and near(task["x"], target[0]) and near(task["y"], target[1]),
              f"robot 1 assigned a goto task to the click: {task}")
        logged = poll(lambda: re.search(r"visit: robot 1 to \(-?0\.\d\d, 2\.\d\d\), asked by web view", read(base_log)), 5)
        check(bool(logged), f"the base logged the web view's visit request: {logged and logged.group(0)!r}")
        check(visits_before == 0, "no visit reached the base before the click")
        shown = poll(lambda: "accepted" in driver.find_element(By.ID, "commands").text, 5)
        check(bool(shown), "the page's Commands table shows it accepted")

        # E-STOP ALL: one SafetyStop for every robot; both fake robots latch (robot 1 stops on its
        # circle), the page then offers both a reset; robot 1's reset makes it drive again.
        driver.find_element(By.ID, "estop-all").click()
        all_latched = poll(lambda: driver.execute_script("""
            const s = window.cairnView.state;
            const c = s.commands.find((x) => x.cmd === "estop_all");
            return c && s.robots.every((r) => r.reset_required) ? c : null;"""), 10)
        # Both fake robots live in one process: one participant, one reader.
        check(bool(all_latched) and "(1 robot reader(s) matched)" in all_latched["result"],
              f"'E-STOP ALL': both robots latched, the base's writer matched the fake robots' reader: {all_latched}")
        robots_log = os.path.join(out, "robots.log")
        check(bool(poll(lambda: read(robots_log).count("remote e-stop by 'web view'") == 2, 5)),
              "each fake robot received the remote e-stop from the web view")
        check(bool(poll(lambda: "remote e-stop of every robot #1 asked by the web view" in read(base_log), 5)),
              "the base logged the e-stop")
        button = poll(lambda: driver.find_elements(By.CSS_SELECTOR, 'button.reset[data-robot="1"]'), 5)
        if button:
            button[0].click()
        again = poll(lambda: driver.execute_script("""
            const s = window.cairnView.state;
            const r1 = s.robots.find((x) => x.id === 1), r2 = s.robots.find((x) => x.id === 2);
            return !r1.reset_required && r2.reset_required ? true : null;"""), 10)
        check(bool(again), "robot 1's reset after the e-stop: robot 1 free, robot 2 still latched")

        errors = [e["message"] for e in driver.get_log("browser") if e["level"] == "SEVERE" and "401" not in e["message"]]
        check(not errors, f"no error in the page's console (the 401s aside): {errors[:3]}")

        shot = os.path.join(out, "web_view.png")
        if os.path.exists(shot):
            os.remove(shot)
        driver.save_screenshot(shot)
        with open(shot, "rb") as f:
            png = f.read()
        check(png[:8] == b"\x89PNG\r\n\x1a\n" and len(png) > 1000, f"screenshot kept ({len(png)} bytes): {shot}")
    finally:
        quit_browser()
        shutil.rmtree(profile, ignore_errors=True)
    check(read(base_log).count("asked by web view") == 1, "only the one visit with the token reached the executive")
    stop_children()
    check(base.returncode == 0, f"cairn-base exited cleanly on SIGTERM (exit {base.returncode})")
    shutil.rmtree(run_dir, ignore_errors=True)
    print(f"web view: {'all checks passed' if failures == 0 else f'{failures} check(s) failed'} in {time.monotonic() - t0:.1f} s "
          f"(logs and screenshot in {out})", flush=True)
    os._exit(0 if failures == 0 else 1)  # os._exit: the watchdog's timer thread does not hold the exit


if __name__ == "__main__":
    try:
        main()
    except Exception as e:  # noqa: BLE001 - any surprise fails the test with its children stopped
        import traceback
        traceback.print_exc()
        fatal(f"unexpected: {e!r}")
