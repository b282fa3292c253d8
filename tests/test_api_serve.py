"""`rig serve` as a real process on loopback: it serves the API, its worker pool runs a
submitted job to success, the job report renders, and SIGTERM stops the service and its
workers."""

from __future__ import annotations

import os
import signal
import socket
import subprocess
import sys
import time

import httpx
import pytest
from api_fixtures import wait_until_serving


def _free_port() -> int:
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


@pytest.mark.slow
def test_rig_serve_runs_a_job_end_to_end(tmp_path):
    from api_fixtures import store_runs
    from db.store import Store
    from db.tokens import create_token

    url = f"sqlite:///{tmp_path / 'rig.sqlite'}"
    with Store(url) as store:
        run_id = store_runs(store)["fast"]
        op = create_token(store, "serve-test", ["operator"])
    port = _free_port()
    env = {**os.environ, "RIG_DB_URL": url, "RIG_API_HOST": "127.0.0.1", "RIG_API_PORT": str(port)}
    proc = subprocess.Popen([sys.executable, "-m", "commands.cli", "serve", "--workers", "1"],
                            env=env, stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True)
    base = f"http://127.0.0.1:{port}"
    h = {"Authorization": f"Bearer {op}"}
    try:
        wait_until_serving(base, proc)
        assert httpx.get(f"{base}/runs").status_code == 401
        r = httpx.post(f"{base}/jobs", headers=h, json={
            "kind": "identification",
            "params": {"run_ids": [run_id], "model": "eq4", "method": "exact",
                       "options": {"draws": 300}}})
        assert r.status_code == 202
        loc = base + r.headers["location"]
        deadline = time.monotonic() + 120
        while (j := httpx.get(loc, headers=h).json())["state"] in ("queued", "running"):
            assert time.monotonic() < deadline, j
            time.sleep(0.2)
        assert j["state"] == "succeeded", j["error"]
        page = httpx.get(f"{base}/reports/jobs/{j['id']}/html", headers=h, timeout=60)
        # predicted vs measured, posterior histograms, corner plot, R-hat trace, autocorrelation
        assert page.status_code == 200 and page.text.count("data:image/svg+xml") == 5
        assert 'alt="predicted_vs_measured"' in page.text
        worker_pid = int(j["worker"].split("/")[1])
        assert worker_pid != proc.pid
    finally:
        proc.send_signal(signal.SIGTERM)
        out = proc.communicate(timeout=60)[0]
    # uvicorn re-raises the SIGTERM after its graceful shutdown (the pool stopped by then)
    assert proc.returncode in (0, -signal.SIGTERM), out
    assert "Application shutdown complete" in out, out
    assert "serving on http://127.0.0.1" in out
    assert not os.path.exists(f"/proc/{worker_pid}") or \
        open(f"/proc/{worker_pid}/stat").read().split(")")[1].split()[0] in ("Z", "X")
