"""The operator console driven in a real headless browser (Debian's chromium through its
chromedriver, via Selenium; no browser is downloaded): `rig serve` runs on loopback; a viewer
signs in and sees no control but E-STOP; an operator starts scheme 1 on the emulator from the
form built from the scheme's schema, watches the live plot grow and the rig-state panel (PLC,
drives, interlocks, e-stop latch) live, presses E-STOP (its keyboard shortcut) and sees the run
end `abort` with the e-stop as its reason and the latch shown latched, opens the run page and its
acceptance table, submits an identification job and opens its report. `/docs` and `/redoc` load
with no asset from outside the service. Screenshots go to env RIG_TEST_ARTIFACTS (default: the
test's tmp dir)."""

from __future__ import annotations

import os
import shutil
import signal
import socket
import subprocess
import sys
import threading
import time
from pathlib import Path

import httpx
import pytest
from api_fixtures import wait_until_serving
from drivers_harness import SLACK_ENV, SLACK_S

CHROMIUM = shutil.which("chromium") or shutil.which("chromium-browser")
CHROMEDRIVER = shutil.which("chromedriver")
pytestmark = [pytest.mark.slow,
              pytest.mark.skipif(CHROMIUM is None or CHROMEDRIVER is None,
                                 reason="needs Debian's chromium and chromium-driver")]

RUN_PARAMS = {"motor_speed_rpm": "300", "load_target": "100000", "ramp_rate": "500",
              "accel_time": "0.5", "settle_time": "0.5", "rest_time": "0.5",
              "sample_rate_hz": "20"}
"""Scheme 1 of ~400 s of rig time, run at time scale 1 (the joint turns ~65°):
e-stopped mid-run."""


def _free_port() -> int:
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


@pytest.fixture(scope="module")
def served(tmp_path_factory):
    """`rig serve --workers 1` on a fresh SQLite store with one stored run and a token per
    role: (base URL, {role: token}, stored run id)."""
    from api_fixtures import store_runs
    from db.store import Store
    from db.tokens import create_token

    tmp = tmp_path_factory.mktemp("console")
    url = f"sqlite:///{tmp / 'rig.sqlite'}"
    with Store(url) as store:
        run_id = store_runs(store)["fast"]
        tokens = {r: create_token(store, f"console-{r}", [r]) for r in ("viewer", "operator")}
    port = _free_port()
    env = {**os.environ, **SLACK_ENV, "RIG_DB_URL": url, "RIG_API_HOST": "127.0.0.1",
           "RIG_API_PORT": str(port)}
    proc = subprocess.Popen([sys.executable, "-m", "commands.cli", "serve", "--workers", "1"],
                            env=env, stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True)
    base = f"http://127.0.0.1:{port}"
    try:
        wait_until_serving(base, proc)
        yield base, tokens, run_id
    finally:
        proc.send_signal(signal.SIGTERM)
        try:
            proc.communicate(timeout=60)
        except subprocess.TimeoutExpired:
            proc.kill()


@pytest.fixture
def browser(tmp_path):
    from selenium import webdriver
    from selenium.webdriver.chrome.service import Service

    os.environ.setdefault("SE_OFFLINE", "true")      # Selenium Manager never downloads
    opts = webdriver.ChromeOptions()
    opts.binary_location = CHROMIUM
    for a in ("--headless=new", "--no-sandbox", "--disable-gpu", "--disable-quic",
              "--no-first-run", "--disable-background-networking", "--disable-component-update",
              "--disable-sync", "--window-size=1400,1000", f"--user-data-dir={tmp_path / 'profile'}"):
        opts.add_argument(a)
    opts.set_capability("goog:loggingPrefs", {"browser": "ALL"})
    drv = webdriver.Chrome(service=Service(CHROMEDRIVER), options=opts)
    drv.set_page_load_timeout(60)
    try:
        yield drv
    finally:
        drv.quit()


class DroppingProxy:
    """A TCP relay on loopback in front of the service, whose `drop(seconds)` cuts every open
    connection and refuses new ones for that long: a network outage as the browser sees it."""

    def __init__(self, target_port: int) -> None:
        self.target = ("127.0.0.1", target_port)
        self.port = _free_port()
        self.conns: list[socket.socket] = []
        self.lock = threading.Lock()
        self._listen()

    def _listen(self) -> None:
        self.server = socket.socket()
        self.server.setsockopt(socket.SOL_SOCKET, socket.SO_REUSEADDR, 1)
        self.server.bind(("127.0.0.1", self.port))
        self.server.listen(64)
        threading.Thread(target=self._accept, args=(self.server,), daemon=True).start()

    def _accept(self, server: socket.socket) -> None:
        while True:
            try:
                client, _ = server.accept()
            except OSError:
                return
            upstream = socket.create_connection(self.target)
            with self.lock:
                self.conns += [client, upstream]
            for a, b in ((client, upstream), (upstream, client)):
                threading.Thread(target=self._pipe, args=(a, b), daemon=True).start()

    @staticmethod
    def _pipe(src: socket.socket, dst: socket.socket) -> None:
        try:
            while data := src.recv(65536):
                dst.sendall(data)
        except OSError:
            pass
        for s in (src, dst):
            try:
                s.shutdown(socket.SHUT_RDWR)
            except OSError:
                pass

    def drop(self, seconds: float) -> None:
        self.server.close()
        with self.lock:
            conns, self.conns = self.conns, []
        for c in conns:
            try:
                c.shutdown(socket.SHUT_RDWR)
                c.close()
            except OSError:
                pass
        threading.Timer(seconds, self._listen).start()


def _shots(tmp_path: Path) -> Path:
    d = Path(os.environ.get("RIG_TEST_ARTIFACTS") or tmp_path)
    d.mkdir(parents=True, exist_ok=True)
    return d


def until(cond, timeout: float = 60.0, what: str = "condition", context=None):
    end = time.monotonic() + timeout
    while True:
        try:
            v = cond()
            if v:
                return v
        except Exception:            # an element not there yet, a stale element
            v = None
        if time.monotonic() > end:
            raise AssertionError(f"timed out waiting for {what}"
                                 + (f": {context()}" if context else ""))
        time.sleep(0.2)


def sign_in(drv, base: str, token: str) -> None:
    from selenium.webdriver.common.by import By
    drv.get(base + "/")
    drv.find_element(By.ID, "token").send_keys(token)
    drv.find_element(By.CSS_SELECTOR, "#signin-form button").click()
    until(lambda: drv.find_element(By.ID, "who").text, 30, "the signed-in role")


RIG_PANEL_JS = """
const box = document.getElementById("rig-state"), out = {live: box.dataset.live,
  estop: document.getElementById("rs-estop").dataset.latched, plc: {}, drives: {}, interlocks: {}};
const groups = {plc: "plc", drive: "drives", interlock: "interlocks"};
for (const e of box.querySelectorAll(".lamp[data-kind]"))
  if (groups[e.dataset.kind]) out[groups[e.dataset.kind]][e.dataset.name] = [e.dataset.state, e.dataset.level];
return out;"""


def rig_panel(drv) -> dict:
    """The rig-state panel as the page shows it, read in one script (the page redraws it with
    every event): whether it is live, the e-stop latch, and each lamp's (state, level) by group
    (plc, drives, interlocks) and name."""
    out = drv.execute_script(RIG_PANEL_JS)
    for group in ("plc", "drives", "interlocks"):
        out[group] = {k: tuple(v) for k, v in out[group].items()}
    return out


def test_viewer_sees_no_controls_but_estop(served, browser, tmp_path):
    from selenium.webdriver.common.by import By
    base, tokens, _ = served
    sign_in(browser, base, tokens["viewer"])
    assert browser.find_element(By.ID, "who").text.endswith("· viewer")
    tabs = [b.get_attribute("data-tab") for b in browser.find_elements(By.CSS_SELECTOR, "nav button")]
    assert tabs == ["live", "runs", "jobs"]                 # no "Run a scheme"
    assert browser.find_elements(By.ID, "stop") == []
    assert browser.find_elements(By.ID, "job-form") == []
    assert browser.find_element(By.ID, "estop").is_displayed()
    # no acquisition yet: the rig-state panel says it knows nothing, and is not live
    assert browser.find_element(By.ID, "rig-state").get_attribute("data-live") == "false"
    assert "no acquisition" in browser.find_element(By.ID, "rs-live").text
    # the console adds no authority: the API still refuses the viewer
    r = httpx.post(f"{base}/schemes/1/runs", headers={"Authorization": f"Bearer {tokens['viewer']}"},
                   json={"target": "emulator", "operator": "x"})
    assert r.status_code == 403
    browser.save_screenshot(str(_shots(tmp_path) / "console-viewer.png"))


def test_operator_runs_estops_and_reports(served, browser, tmp_path):
    from selenium.webdriver.common.by import By
    from selenium.webdriver.common.keys import Keys
    from selenium.webdriver.support.ui import Select

    base, tokens, stored_run = served
    shots = _shots(tmp_path)
    proxy = DroppingProxy(int(base.rsplit(":", 1)[1]))
    base = f"http://127.0.0.1:{proxy.port}"
    sign_in(browser, base, tokens["operator"])
    browser.find_element(By.CSS_SELECTOR, "nav button[data-tab=schemes]").click()
    until(lambda: browser.find_element(By.NAME, "params.motor_speed_rpm"), 30, "the scheme form")
    for name, value in RUN_PARAMS.items():
        e = browser.find_element(By.NAME, f"params.{name}")
        e.clear()
        e.send_keys(value)
    for name, value in (("time_scale", "1"), ("watchdog_s", str(SLACK_S))):
        e = browser.find_element(By.NAME, f"emulator.{name}")
        e.clear()
        e.send_keys(value)
    # a refused value is shown inline, beside its field
    speed = browser.find_element(By.NAME, "params.motor_speed_rpm")
    browser.execute_script("arguments[0].removeAttribute('max')", speed)
    speed.clear()
    speed.send_keys("1e9")
    browser.find_element(By.CSS_SELECTOR, "#scheme-form button[type=submit]").click()
    until(lambda: browser.find_element(
        By.CSS_SELECTOR, '.field-error[data-for="params.motor_speed_rpm"]').text, 30,
        "the inline refusal")
    speed.clear()
    speed.send_keys(RUN_PARAMS["motor_speed_rpm"])
    browser.save_screenshot(str(shots / "console-scheme-form.png"))
    browser.find_element(By.CSS_SELECTOR, "#scheme-form button[type=submit]").click()

    # the live plot grows
    pts = lambda: int(browser.find_element(By.ID, "live-plots").get_attribute("data-points") or 0)
    direct = served[0]

    def seen():
        acqs = httpx.get(f"{direct}/acquisitions",
                         headers={"Authorization": f"Bearer {tokens['operator']}"}).json()
        return ({k: browser.find_element(By.ID, k).text
                 for k in ("acq-state", "acq-run", "banner", "scheme-error")},
                [{k: a.get(k) for k in ("state", "run_status", "reason", "requests", "log_tail")}
                 for a in acqs])
    first = until(lambda: pts() >= 10 and pts(), 120, "live points", seen)
    until(lambda: pts() > first + 10, 60, "the live plot to grow")
    assert browser.find_element(By.ID, "acq-state").text in ("running", "starting")
    # the rig-state panel, live: PLC running, three drives enabled, no interlock tripped,
    # the e-stop released (read back from the page's lamps)
    until(lambda: rig_panel(browser)["live"] == "true" and rig_panel(browser)["drives"], 60,
          "the live rig state", lambda: rig_panel(browser))
    panel = rig_panel(browser)
    assert panel["plc"]["mode"] in (("run", "ok"), ("ready", "ok")), panel
    assert panel["plc"]["link"] == ("up", "ok") and panel["plc"]["fault"] == ("none", "ok"), panel
    assert panel["drives"] == {f"m{k}": ("OPERATION ENABLED", "ok") for k in (1, 2, 3)}, panel
    assert {"torque", "angle", "estop", "plc_link", "drive_link"} <= set(panel["interlocks"])
    assert all(v == ("ok", "ok") for v in panel["interlocks"].values()), panel
    assert panel["estop"] == "false", panel
    browser.save_screenshot(str(shots / "console-live.png"))

    # the connection drops for 3 s (the proxy between browser and service closes every
    # connection and refuses new ones): the view says so, reconnects, and keeps plotting
    proxy.drop(3.0)
    until(lambda: "lost" in browser.find_element(By.ID, "banner").text, 30, "the lost banner")
    until(lambda: "Reconnected" in browser.find_element(By.ID, "banner").text, 30,
          "the reconnected banner")
    after = pts()
    until(lambda: pts() > after + 5, 60, "the live plot to grow after the reconnection")

    # E-STOP by its keyboard shortcut: no dialog, the run ends abort with the e-stop reason
    browser.find_element(By.TAG_NAME, "body").send_keys(Keys.ESCAPE)
    final = until(lambda: browser.find_element(By.ID, "acq-run").get_attribute("data-final"),
                  90, "the run's end", seen)
    reason = browser.find_element(By.ID, "acq-run").get_attribute("data-reason")
    assert final == "abort" and "e-stop" in reason.lower(), (final, reason, seen())
    # the panel shows the e-stop latched and the estop interlock tripped, as the last known
    # state (the acquisition has ended: not live)
    until(lambda: rig_panel(browser)["estop"] == "true", 30, "the e-stop latch",
          lambda: rig_panel(browser))
    panel = rig_panel(browser)
    assert "E-STOP LATCHED" in browser.find_element(By.ID, "rs-estop").text
    assert panel["interlocks"]["estop"] == ("tripped", "bad"), panel
    assert panel["plc"]["safe"] == ("safe", "bad"), panel
    until(lambda: rig_panel(browser)["live"] == "false", 10, "the panel to say it is not live")
    assert "NOT LIVE" in browser.find_element(By.ID, "rs-live").text
    browser.save_screenshot(str(shots / "console-estopped.png"))

    # the run page: plots and the Table 11 acceptance table
    browser.find_element(By.CSS_SELECTOR, "#acq-run a").click()
    until(lambda: browser.find_elements(By.CSS_SELECTOR, "#run-acceptance tr"), 60,
          "the acceptance table")
    until(lambda: int(browser.find_element(By.ID, "run-plot").get_attribute("data-points") or 0)
          > 10, 60, "the run's plots")
    assert "abort" in browser.find_element(By.ID, "run-title").text
    browser.save_screenshot(str(shots / "console-run.png"))

    # an identification job on the stored run, its report opened in the console
    browser.find_element(By.CSS_SELECTOR, "nav button[data-tab=jobs]").click()
    until(lambda: browser.find_element(By.NAME, "model"), 30, "the job form")
    Select(browser.find_element(By.ID, "job-kind")).select_by_value("identification")
    browser.find_element(By.ID, "job-runs").send_keys(str(stored_run))
    browser.find_element(By.NAME, "model").send_keys("eq4")
    Select(browser.find_element(By.NAME, "method")).select_by_value("exact")
    browser.find_element(By.CSS_SELECTOR, "#job-form button[type=submit]").click()
    until(lambda: browser.find_elements(By.CSS_SELECTOR,
                                        "#jobs-body tr[data-state=succeeded] button"),
          180, "the job to succeed")
    browser.find_element(By.CSS_SELECTOR, "#jobs-body tr[data-state=succeeded] button").click()
    until(lambda: "Identification tables" in (browser.find_element(
        By.ID, "report-frame").get_attribute("srcdoc") or ""), 60, "the job report")
    browser.save_screenshot(str(shots / "console-job-report.png"))
    expected = ("/schemes/1/runs - Failed to load resource",   # the 422 above
                "/rig-model - Failed to load resource",        # 404: no fit marked yet
                "net::ERR_")                                   # the outage the proxy made
    errors = [e for e in browser.get_log("browser") if e["level"] == "SEVERE"
              and not any(x in e["message"] for x in expected)]
    assert errors == [], errors


def test_api_docs_load_offline(served, browser):
    from selenium.webdriver.common.by import By
    base, _, _ = served
    for path, asset in (("/docs", "/docs-assets/swagger-ui-bundle.js"),
                        ("/redoc", "/docs-assets/redoc.standalone.js")):
        html = httpx.get(base + path).text
        assert asset in html and "cdn" not in html.lower() and "googleapis" not in html
        assert httpx.get(base + asset).status_code == 200
    browser.get(base + "/docs")
    until(lambda: browser.find_elements(By.CSS_SELECTOR, ".opblock"), 60, "Swagger UI's operations")
    browser.get(base + "/redoc")
    until(lambda: "J4 test platform" in browser.find_element(By.TAG_NAME, "body").text
          or browser.find_elements(By.CSS_SELECTOR, "[data-section-id]"), 60, "ReDoc's page")
