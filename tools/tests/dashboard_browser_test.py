"""`sma dashboard` end to end in headless Chromium against the firmware in the virtual rig.

Run by CTest (test dashboard_browser, with $SMA_VRIG and $SMA_ELF set); the file name keeps it
out of the plain `pytest tools/tests` run, which has no firmware. Checks what a user relies on:
the page shows a moving trace, a command typed on the page reaches the board (the reference in
the telemetry follows it), a command the board refuses shows its ERR on the page and in the
terminal, the stop button turns the heater off (duty 0 in the telemetry), a second page only
watches, `sma upload` cannot take the port while the dashboard holds it and can after "Release
port", and a port that cannot be opened is named on the page and in the terminal. Saves the
screenshot docs/img/dashboard.png (with --screenshot-to or $SMA_SCREENSHOT).
"""
import json
import os
import shutil
import signal
import subprocess
import sys
import time

import pytest

HERE = os.path.dirname(os.path.abspath(__file__))
ROOT = os.path.dirname(os.path.dirname(HERE))
SMA = os.path.join(ROOT, "tools", "sma")
sys.path.insert(0, os.path.join(ROOT, "tools", "vrig"))
sys.path.insert(0, os.path.join(ROOT, "tools", "py"))

VRIG, ELF = os.environ.get("SMA_VRIG"), os.environ.get("SMA_ELF")
pytestmark = pytest.mark.skipif(not (VRIG and ELF and os.path.isfile(VRIG) and os.path.isfile(ELF)),
                                reason="needs $SMA_VRIG and $SMA_ELF (CTest sets them)")


def chromium_driver():
    webdriver = pytest.importorskip("selenium.webdriver")
    from selenium.webdriver.chrome.options import Options
    from selenium.webdriver.chrome.service import Service

    binary = shutil.which("chromium") or shutil.which("chromium-browser")
    driver = shutil.which("chromedriver")
    if not binary or not driver:
        pytest.skip("chromium / chromium-driver not installed (bash scripts/setup)")
    opts = Options()
    opts.binary_location = binary
    for a in ("--headless=new", "--no-sandbox", "--disable-gpu", "--disable-dev-shm-usage", "--window-size=1400,900"):
        opts.add_argument(a)
    return webdriver.Chrome(service=Service(driver), options=opts)


class Dashboard:
    """`tools/sma dashboard` as a user starts it; its terminal output is kept."""

    def __init__(self, tmp, port):
        self.url_file = os.path.join(tmp, "url.txt")
        self.err_path = os.path.join(tmp, "dashboard.err")
        self.err = open(self.err_path, "w")
        self.proc = subprocess.Popen([sys.executable, SMA, "dashboard", "--port", port, "--http-port", "0",
                                      "--record-dir", tmp, "--url-file", self.url_file],
                                     stdout=self.err, stderr=self.err)
        end = time.time() + 20
        while not os.path.exists(self.url_file) and time.time() < end:
            assert self.proc.poll() is None, self.terminal()
            time.sleep(0.1)
        with open(self.url_file) as f:
            self.url = f.readline().strip()

    def terminal(self):
        self.err.flush()
        with open(self.err_path) as f:
            return f.read()

    def close(self):
        if self.proc.poll() is None:
            self.proc.send_signal(signal.SIGINT)
            self.proc.wait(timeout=20)
        self.err.close()


def wait_for(cond, timeout, what):
    end = time.time() + timeout
    while time.time() < end:
        v = cond()
        if v:
            return v
        time.sleep(0.2)
    raise AssertionError("timed out waiting for " + what)


def rows(browser):
    """The telemetry rows the page holds (the page's own data, as it draws them)."""
    return browser.execute_script("return rows.slice(-50);")


@pytest.fixture(scope="module")
def board(tmp_path_factory):
    from pty_board import PtyBoard

    with PtyBoard(VRIG, ELF, duration=600, extra=["--noise-mm", "0.002"]) as b:
        yield b


def test_dashboard_in_headless_chromium(board, tmp_path):
    dash = Dashboard(str(tmp_path), board.port)
    browser = chromium_driver()
    try:
        browser.get(dash.url)
        # a moving trace: telemetry time advances on the page
        t1 = wait_for(lambda: (rows(browser) or [[None]])[-1][0], 20, "telemetry on the page")
        wait_for(lambda: rows(browser)[-1][0] > t1 + 0.5, 20, "the trace to move")
        wait_for(lambda: "controls the rig" in browser.find_element("id", "role").text, 10, "control of the rig")

        # a command typed on the page reaches the board: the reference follows it, heater on
        box = browser.find_element("id", "cmd")
        box.send_keys("pos 0.45")
        browser.find_element("id", "send").click()
        wait_for(lambda: any(abs(r[3] - 0.45) < 1e-6 and r[4] > 0 for r in rows(browser)), 20,
                 "ref_mm 0.45 with the heater on in the telemetry")
        assert "OK pos 0.4500" in browser.find_element("id", "log").text

        # the latch and the firmware's temperature are shown
        wait_for(lambda: "latch: none" in browser.find_element("id", "latch").text, 10, "latch state")
        # heating to 0.45 mm takes the wire through its transformation (T_AS 50.4, T_AF 80.1 degC)
        wait_for(lambda: browser.execute_script("return Math.max(...temps.map(p => p[1]))") > 50.4, 20,
                 "the estimated temperature above A_s on the page")

        # a command the board refuses: its ERR on the page and in the terminal
        box.send_keys("pos 5")
        browser.find_element("id", "send").click()
        err = wait_for(lambda: browser.find_element("id", "error").text, 10, "the refusal on the page")
        assert "refused 'pos 5'" in err and "ERR pos" in err
        wait_for(lambda: "board: ERR pos" in dash.terminal(), 5, "the refusal in the terminal")

        # recording to a rig log
        browser.find_element("id", "recfile").send_keys("rec.csv")
        browser.find_element("id", "rec").click()
        time.sleep(2.0)
        browser.find_element("id", "rec").click()
        wait_for(lambda: "recorded" in dash.terminal(), 10, "the recording to end")
        from sma import riglog

        rec = riglog.read(str(tmp_path / "rec.csv"))
        assert len(rec) > 50 and rec["ref_mm"][-1] == pytest.approx(0.45)

        shot = os.environ.get("SMA_SCREENSHOT")
        if shot:
            time.sleep(3.0)  # a few seconds of trace on the plots
            os.makedirs(os.path.dirname(shot), exist_ok=True)
            browser.save_screenshot(shot)

        # the stop button turns the heater off: duty 0 and v 0 in the telemetry from then on
        browser.find_element("id", "stop").click()
        wait_for(lambda: all(r[4] == 0 and r[1] == 0 for r in rows(browser)[-20:]), 10, "heater off")
        assert "heater off" in dash.terminal()

        # a second page only watches
        second = chromium_driver()
        try:
            second.get(dash.url)
            wait_for(lambda: "watching only" in second.find_element("id", "role").text, 10, "second page watching")
        finally:
            second.quit()

        # the port is not shared with sma upload while the dashboard holds it ...
        params = tmp_path / "p.json"
        params.write_text("{}")
        env = dict(os.environ)
        up = subprocess.run([sys.executable, SMA, "upload", str(params), "--port", board.port],
                            capture_output=True, text=True, env=env)
        assert up.returncode == 2 and "in use by another program" in up.stderr, up.stderr
        # ... and is after "Release port"
        browser.find_element("id", "release").click()
        wait_for(lambda: "not connected" in browser.find_element("id", "conn").text, 10, "release")
        probe = subprocess.run([sys.executable, SMA, "console", "--port", board.port, "--send", "status", "-q"],
                               capture_output=True, text=True)
        assert probe.returncode == 0, probe.stderr
        browser.find_element("id", "connect").click()
        wait_for(lambda: "connected " in browser.find_element("id", "conn").text
                 and "not" not in browser.find_element("id", "conn").text, 10, "reconnect")
    finally:
        browser.quit()
        dash.close()


def assert_port_error_shown(tmp_path, port, text):
    """The dashboard started on a port it cannot take: `text` on the page and in the terminal."""
    dash = Dashboard(str(tmp_path), port)
    browser = chromium_driver()
    try:
        browser.get(dash.url)
        err = wait_for(lambda: browser.find_element("id", "error").text, 10, "the error on the page")
        assert text in err
        assert text in dash.terminal()
    finally:
        browser.quit()
        dash.close()


def test_a_port_that_cannot_be_opened_is_named_on_the_page_and_in_the_terminal(tmp_path):
    assert_port_error_shown(tmp_path, "/dev/nonexistent-sma-port", "cannot open /dev/nonexistent-sma-port")


def test_a_port_in_use_is_named(board, tmp_path):
    # another program holds the port (here: a console session, which opens it exclusively)
    holder = subprocess.Popen([sys.executable, SMA, "console", "--port", board.port, "--duration", "15", "-q",
                               "--status", "0"], stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
    try:
        time.sleep(2.0)
        assert_port_error_shown(tmp_path, board.port, "in use by another program")
    finally:
        holder.send_signal(signal.SIGINT)
        holder.wait(timeout=20)


def test_listens_on_localhost_only_and_refuses_foreign_hosts(board, tmp_path):
    import urllib.request
    import urllib.error

    dash = Dashboard(str(tmp_path), "loop://")
    try:
        assert dash.url.startswith("http://127.0.0.1:")
        req = urllib.request.Request(dash.url + "api/state", headers={"Host": "evil.example:80"})
        with pytest.raises(urllib.error.HTTPError) as e:
            urllib.request.urlopen(req, timeout=5)
        assert e.value.code == 403
        req = urllib.request.Request(dash.url + "api/command", data=b"line=stop", method="POST",
                                     headers={"Content-Type": "application/x-www-form-urlencoded"})
        with pytest.raises(urllib.error.HTTPError) as e:
            urllib.request.urlopen(req, timeout=5)
        assert e.value.code == 415
        st = json.load(urllib.request.urlopen(dash.url + "api/state", timeout=5))
        assert st["port"] == "loop://"
    finally:
        dash.close()
