"""Load check of the operator console's live view: `python bench/bench_console.py [--browsers 5]`.

Starts `rig serve` on loopback (a fresh SQLite store), opens N headless Chromium browsers
(Debian's chromium and chromedriver, via Selenium) on the console's live view, starts scheme 1 on
the emulator and follows it to its end. Every progress event carries the service's send time
(`sent_at`); each browser records its delivery latency (receipt − send, one clock: the same
machine). Printed: the delivery latency p50/p99 in the browsers next to a plain HTTP client
reading the same event stream at the same time (the peer: no browser, no drawing), the events
each browser drew per second — over the whole acquisition (start request to its end, which
includes starting the stand-in and `rig run`, homing, and making safe, when no progress
flows) and over the live span (first to last progress event received) with the longest gap
between two — and the service's CPU (user + system over the run, from /proc).
Targets: p99 < 250 ms with 5 browsers; at least 4 live updates per second."""

from __future__ import annotations

import argparse
import json
import os
import shutil
import signal
import socket
import subprocess
import sys
import tempfile
import threading
import time
from pathlib import Path

import httpx
import numpy as np

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

SCHEME1 = {"motor_speed_rpm": 3000.0, "load_target": 100e3, "ramp_rate": 2.5e3,
           "accel_time": 0.5, "settle_time": 0.5, "rest_time": 0.5, "sample_rate_hz": 20.0}
"""Scheme 1 of ~82 s of rig time, at time scale 2: ~41 s of wall time."""


def _free_port() -> int:
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


def _cpu_s(pid: int) -> float:
    """User + system CPU of process `pid` so far [s] (the web process: its acquisitions run in
    processes of their own)."""
    fields = open(f"/proc/{pid}/stat").read().rsplit(")", 1)[1].split()
    tick = os.sysconf("SC_CLK_TCK")
    return sum(int(fields[i]) for i in (11, 12)) / tick


def _raw_client(base: str, token: str, acq: str, out: list[float], stop: threading.Event):
    """The peer: one plain HTTP client on the same event stream, recording delivery latency."""
    with httpx.stream("GET", f"{base}/acquisitions/{acq}/events", timeout=None,
                      headers={"Authorization": f"Bearer {token}"}) as r:
        ev = None
        for line in r.iter_lines():
            if line.startswith("event: "):
                ev = line[7:]
            elif line.startswith("data: ") and ev == "progress":
                d = json.loads(line[6:])
                if d.get("sent_at"):
                    out.append(time.time() - d["sent_at"])
            if stop.is_set() or ev == "end":
                return


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--browsers", type=int, default=5)
    ap.add_argument("--time-scale", type=float, default=2.0)
    a = ap.parse_args(argv)
    chromium, driver = shutil.which("chromium"), shutil.which("chromedriver")
    if not chromium or not driver:
        print("needs Debian's chromium and chromium-driver (apt-get install chromium "
              "chromium-driver)", file=sys.stderr)
        return 2
    from selenium import webdriver
    from selenium.webdriver.chrome.service import Service
    from selenium.webdriver.common.by import By

    from db.store import Store
    from db.tokens import create_token

    tmp = Path(tempfile.mkdtemp(prefix="bench-console-"))
    url = f"sqlite:///{tmp / 'rig.sqlite'}"
    with Store(url) as store:
        op = create_token(store, "bench-operator", ["operator"])
        viewer = create_token(store, "bench-viewer", ["viewer"])
    port = _free_port()
    env = {**os.environ, "RIG_DB_URL": url, "RIG_API_HOST": "127.0.0.1",
           "RIG_API_PORT": str(port), "RIG_PLC_LINK_TIMEOUT": "2", "RIG_DRIVE_HEARTBEAT_TIMEOUT": "2"}
    srv = subprocess.Popen([sys.executable, "-m", "commands.cli", "serve", "--workers", "0"],
                           env=env, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
    base = f"http://127.0.0.1:{port}"
    browsers = []
    os.environ.setdefault("SE_OFFLINE", "true")
    try:
        deadline = time.monotonic() + 60
        while True:
            try:
                if httpx.get(base + "/openapi.json", timeout=1).status_code == 200:
                    break
            except httpx.TransportError:
                pass
            if time.monotonic() > deadline:
                raise SystemExit("rig serve did not come up")
            time.sleep(0.2)
        for k in range(a.browsers):
            o = webdriver.ChromeOptions()
            o.binary_location = chromium
            for arg in ("--headless=new", "--no-sandbox", "--disable-gpu", "--disable-quic",
                        "--no-first-run", "--disable-background-networking",
                        "--disable-component-update", "--disable-sync", "--window-size=1400,1000",
                        f"--user-data-dir={tmp / f'profile{k}'}"):
                o.add_argument(arg)
            d = webdriver.Chrome(service=Service(driver), options=o)
            d.get(base + "/")
            d.find_element(By.ID, "token").send_keys(viewer)
            d.find_element(By.CSS_SELECTOR, "#signin-form button").click()
            browsers.append(d)
        r = httpx.post(f"{base}/schemes/1/runs", headers={"Authorization": f"Bearer {op}"},
                       json={"target": "emulator", "operator": "bench", "params": SCHEME1,
                             "emulator": {"time_scale": a.time_scale, "watchdog_s": 2.0}})
        r.raise_for_status()
        acq = r.json()["id"]
        cpu0, t0 = _cpu_s(srv.pid), time.monotonic()
        raw: list[float] = []
        stop = threading.Event()
        th = threading.Thread(target=_raw_client, args=(base, viewer, acq, raw, stop), daemon=True)
        th.start()
        deadline = time.monotonic() + 600
        while httpx.get(f"{base}/acquisitions/{acq}", headers={
                "Authorization": f"Bearer {viewer}"}).json()["state"] != "ended":
            if time.monotonic() > deadline:
                raise SystemExit("the run did not end within 600 s")
            time.sleep(0.5)
        wall = time.monotonic() - t0
        cpu = _cpu_s(srv.pid) - cpu0
        stop.set()
        time.sleep(1.0)
        lat = [x for d in browsers for x in d.execute_script("return window.__latencies || []")]
        counts = [len(d.execute_script("return window.__latencies || []")) for d in browsers]
        received = [np.asarray(d.execute_script("return window.__received || []"), dtype=float)
                    for d in browsers]
    finally:
        for d in browsers:
            d.quit()
        srv.send_signal(signal.SIGTERM)
        try:
            srv.wait(timeout=60)
        except subprocess.TimeoutExpired:
            srv.kill()
        shutil.rmtree(tmp, ignore_errors=True)

    def q(x, p):
        return 1e3 * float(np.percentile(x, p)) if len(x) else float("nan")
    print(f"console live view, {a.browsers} browsers, one scheme-1 run of {wall:.1f} s wall "
          f"(time scale {a.time_scale:g}), load average {os.getloadavg()[0]:.1f}")
    print(f"{'':34} {'p50 [ms]':>9} {'p99 [ms]':>9} {'events':>7}")
    print(f"{'browsers (ours, drawing)':34} {q(lat, 50):9.1f} {q(lat, 99):9.1f} {len(lat):7d}"
          f"   target p99 < 250 ms: {'ok' if q(lat, 99) < 250 else 'NO'}")
    print(f"{'plain HTTP client (peer)':34} {q(raw, 50):9.1f} {q(raw, 99):9.1f} {len(raw):7d}")
    span = [(len(r) - 1) / (r[-1] - r[0]) if len(r) > 1 and r[-1] > r[0] else float("nan")
            for r in received]
    gaps = np.concatenate([np.diff(r) for r in received if len(r) > 1] or [np.zeros(0)])
    print(f"events per browser per second: {np.mean(counts) / wall:.2f} (min {min(counts) / wall:.2f})"
          f" over the whole acquisition; {np.nanmean(span):.2f} (min {np.nanmin(span):.2f}) over "
          f"the live span, target ≥ 4: {'ok' if np.nanmin(span) >= 4 else 'NO'}; gap between "
          f"updates p99 {q(gaps, 99):.0f} ms, max {1e3 * gaps.max() if len(gaps) else float('nan'):.0f} ms")
    print(f"service CPU {cpu:.1f} s over {wall:.1f} s = {100 * cpu / wall:.0f} % of one core")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
