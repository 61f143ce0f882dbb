# The operator console in a real browser: `acomm demo --web` runs the
# mission paced, and headless Chromium (Debian's, driven by Playwright
# through executable_path; nothing downloads a browser) loads the page and
# checks in the DOM that
#   - the three nodes appear;
#   - a chat line typed into the page arrives at the diver's node in the
#     simulation (the demo prints what reaches the diver from the console);
#   - the plan view places the diver within the USBL's error of its true
#     position (the demo's /api/sim says where the diver is and how large
#     the X150's errors are);
#   - the diver's alarm shows and is acknowledged;
#   - on a phone's screen the page is one column, no wider than the screen.
# Screenshots go to build/artefacts/console/ (git-ignored); docs/img/ keeps
# one set of them. The mission runs at 40x real time so that the alarm
# (390 s into the mission) comes within about 10 s.
import json
import math
import os
import queue
import shutil
import signal
import subprocess
import sys
import threading
import time
import urllib.request

import pytest

from consoleprocs import free_port

ROOT = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))
ART = os.path.join(ROOT, "build", "artefacts", "console")
FLAGS = ["--no-sandbox", "--disable-gpu", "--disable-quic", "--no-first-run", "--disable-background-networking",
         "--disable-component-update", "--disable-sync"]
SPEED = 40


def _browser():
    for n in ("chromium", "chromium-browser"):
        p = shutil.which(n)
        if p:
            return p
    return None



class Demo:
    # `acomm demo --web` in a process; its timeline lines in a queue
    def __init__(self, tmp_path, port):
        self.port = port
        self.lines = []
        self.q = queue.Queue()
        env = dict(os.environ, PYTHONUNBUFFERED="1")
        self.p = subprocess.Popen(
            [sys.executable, "-m", "acomm_cpython.cli", "demo", "--web", "127.0.0.1:%d" % port, "--speed", str(SPEED),
             "--no-plots", "--out", str(tmp_path / "out"), "--linger"],
            stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True, env=env, cwd=ROOT)
        threading.Thread(target=self._read, daemon=True).start()

    def _read(self):
        for ln in self.p.stdout:
            self.q.put(ln.rstrip("\n"))

    def wait_line(self, text, timeout):
        end = time.monotonic() + timeout
        for ln in self.lines:
            if text in ln:
                return ln
        while time.monotonic() < end:
            try:
                ln = self.q.get(timeout=0.2)
            except queue.Empty:
                if self.p.poll() is not None and self.q.empty():
                    break
                continue
            self.lines.append(ln)
            if text in ln:
                return ln
        raise AssertionError("no line with %r within %g s; the demo said:\n%s" % (text, timeout, "\n".join(self.lines[-30:])))

    def get(self, path):
        with urllib.request.urlopen("http://127.0.0.1:%d%s" % (self.port, path), timeout=5) as r:
            return json.loads(r.read())

    def stop(self):
        if self.p.poll() is None:
            self.p.send_signal(signal.SIGTERM)
        try:
            return self.p.wait(10)
        except subprocess.TimeoutExpired:
            self.p.kill()
            return self.p.wait()


def test_the_console_shows_the_mission_in_a_browser(tmp_path):
    exe = _browser()
    if exe is None:
        pytest.skip("no chromium: run tools/browser.py as root (make test does) or 'apt-get install chromium'")
    try:
        from playwright.sync_api import sync_playwright
    except ImportError:
        pytest.skip("no playwright: pip install -e '.[dev]'")
    os.makedirs(ART, exist_ok=True)
    demo = Demo(tmp_path, free_port())
    try:
        demo.wait_line("console: http://", 30)
        with sync_playwright() as pw:
            browser = pw.chromium.launch(executable_path=exe, headless=True, args=FLAGS)
            try:
                page = browser.new_page(viewport={"width": 1280, "height": 1000})
                page.goto("http://127.0.0.1:%d/" % demo.port)
                # the three nodes, named
                for name in ("buoy", "diver", "auv"):
                    page.wait_for_selector("#nodes tr[data-node=%s]" % name, timeout=20000)
                assert page.locator("#me").inner_text().startswith("buoy")
                page.screenshot(path=os.path.join(ART, "1-nodes.png"), full_page=True)

                # a chat line typed into the page reaches the diver
                page.select_option("#dst", "diver")
                page.fill("#chat-text", "hello from the browser")
                page.click("#chat-send")
                page.wait_for_function("document.getElementById('answer').textContent.includes('queued')",
                                       timeout=5000)
                demo.wait_line("diver <- buoy chat 'hello from the browser' (from the console)", 30)
                page.wait_for_selector("#log tr[data-cls=chat]", timeout=5000)

                # range the diver from its row; the plan view shows its USBL fix
                page.click("#nodes tr[data-node=diver] button.range")
                page.wait_for_function("document.getElementById('answer').textContent.includes('range')", timeout=5000)
                fix = page.wait_for_selector("#plan circle.fix[data-node=diver]", timeout=20000)
                east, north = float(fix.get_attribute("data-east")), float(fix.get_attribute("data-north"))
                sim = demo.get("/api/sim")
                te, tn, _ = sim["truth"]["diver"]
                dist = math.hypot(te, tn, sim["truth"]["diver"][2] - sim["truth"]["buoy"][2])
                # the worst horizontal error of the X150's noise: the range
                # error, the bearing error at that range (azimuth and
                # elevation), and the fix's 0.1 m resolution
                noise = sim["usbl_noise"]
                tol = noise["range_m"] + 2 * dist * math.radians(noise["bearing_deg"]) + 0.2
                err = math.hypot(east - te, north - tn)
                assert err <= tol, (east, north, te, tn, err, tol)
                page.wait_for_selector("#plan circle.range[data-node=diver]", timeout=5000)
                page.screenshot(path=os.path.join(ART, "2-plan.png"), full_page=True)

                # the diver's alarm shows, and stays until acknowledged
                alarm = page.wait_for_selector("#alarms .alarm[data-from=diver]:not(.acked)", timeout=30000)
                assert "low_air" in alarm.inner_text()
                page.screenshot(path=os.path.join(ART, "3-alarm.png"), full_page=True)
                alarm.query_selector("button.ack").click()
                page.wait_for_selector("#alarms .alarm.acked[data-from=diver]", timeout=5000)
                assert "acknowledged by operator@127.0.0.1" in page.locator("#alarms").inner_text()
                assert demo.get("/api/view/alarms")["data"]["unacked"] == 0
                page.screenshot(path=os.path.join(ART, "4-acknowledged.png"), full_page=True)

                # on a phone: one column, nothing wider than the screen
                page.set_viewport_size({"width": 390, "height": 844})
                page.wait_for_timeout(300)
                assert page.evaluate("document.documentElement.scrollWidth") <= 390
                page.screenshot(path=os.path.join(ART, "5-phone.png"))
            finally:
                browser.close()
        demo.wait_line("-> 200", 5)  # the acknowledgement, logged with who sent it
    finally:
        rc = demo.stop()
    assert rc == 0, "\n".join(demo.lines[-20:])
