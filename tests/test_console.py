"""The console's server side without a browser: the page and its assets are served by the app
with nothing from outside it, /docs and /redoc load their scripts from the service, /me names the
token's role, a run downloads in the interchange format (and reads back), and `rig demo --serve`'s
last step prints the console's address with a working operator token."""

from __future__ import annotations

import io
import os
import re
import subprocess
import sys
import time
import zipfile

import httpx
import pytest
from api_fixtures import get


def test_console_page_and_assets_come_from_the_service(api):
    page = api.client.get("/")
    assert page.status_code == 200 and page.headers["content-type"].startswith("text/html")
    srcs = re.findall(r'(?:src|href)="([^"]+)"', page.text)
    assert srcs and all(s.startswith("/console/") for s in srcs), srcs
    for s in srcs:
        r = api.client.get(s)
        assert r.status_code == 200 and len(r.content) > 500, s
    js = api.client.get("/console/console.js").text
    assert "http://" not in js and "https://" not in js        # nothing fetched from outside
    assert api.client.get("/console/../settings.py").status_code == 404
    assert api.client.get("/console/secret.txt").status_code == 404


def test_docs_and_redoc_load_their_assets_from_the_service(api):
    for path, asset in (("/docs", "/docs-assets/swagger-ui-bundle.js"),
                        ("/redoc", "/docs-assets/redoc.standalone.js")):
        html = api.client.get(path).text
        urls = re.findall(r'(?:src|href)="([^"]+)"', html) + re.findall(r"url: ?'([^']+)'", html)
        assert asset in urls, urls
        assert all(u.startswith("/") for u in urls), urls   # no CDN, no Google fonts
        r = api.client.get(asset)
        assert r.status_code == 200 and len(r.content) > 100_000
    assert api.client.get("/docs-assets/other.js").status_code == 404


def test_me_names_the_role_and_needs_a_token(api):
    assert api.client.get("/me").status_code == 401
    for role in ("viewer", "operator"):
        me = get(api, "/me") if role == "viewer" else api.client.get(
            "/me", headers=api.h(role)).json()
        assert me["role"] == role and me["roles"][0] == "viewer"


def test_a_run_downloads_in_the_interchange_format(api, tmp_path):
    from core.runfile import read_run

    run_id = api.runs["fast"]
    r = api.client.get(f"/runs/{run_id}/file", headers=api.h("viewer"))
    assert r.status_code == 200 and r.headers["content-type"] == "application/zip"
    with zipfile.ZipFile(io.BytesIO(r.content)) as z:
        assert sorted(z.namelist()) == [f"run-{run_id}.csv", f"run-{run_id}.json"]
        z.extractall(tmp_path)
    back = read_run(tmp_path / f"run-{run_id}.csv")
    stored = api.store.load_run(run_id)
    assert len(back) == len(stored) and list(back.samples.columns) == list(stored.samples.columns)
    assert api.client.get(f"/runs/{run_id}/file").status_code == 401
    assert api.client.get("/runs/999999/file", headers=api.h("viewer")).status_code == 404


def test_demo_serve_prints_the_console_address_and_a_working_token(tmp_path):
    import socket
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        port = s.getsockname()[1]
    env = {**os.environ, "RIG_DB_URL": f"sqlite:///{tmp_path / 'rig.sqlite'}"}
    proc = subprocess.Popen([sys.executable, "-c", "from commands.cmd_demo import serve_console; "
                             f"serve_console({port})"], env=env, stdout=subprocess.PIPE,
                            stderr=subprocess.STDOUT, text=True)
    try:
        lines = []
        deadline = time.monotonic() + 120
        while not any("token" in ln for ln in lines[:-1]):
            assert time.monotonic() < deadline and proc.poll() is None, lines
            lines.append(proc.stdout.readline())
        text = "".join(lines)
        assert f"http://127.0.0.1:{port}/" in text
        token = lines[-1].strip()
        while True:
            try:
                me = httpx.get(f"http://127.0.0.1:{port}/me",
                               headers={"Authorization": f"Bearer {token}"}, timeout=2)
                break
            except httpx.TransportError:
                assert time.monotonic() < deadline and proc.poll() is None
                time.sleep(0.2)
        assert me.status_code == 200 and me.json()["role"] == "operator"
        assert httpx.get(f"http://127.0.0.1:{port}/").status_code == 200
    finally:
        proc.terminate()
        proc.wait(timeout=60)


@pytest.fixture(scope="module")
def api(tmp_path_factory):
    from api_fixtures import _api, database
    with database("sqlite", tmp_path_factory) as url:
        yield from _api(url)


def test_the_job_list_names_each_jobs_results(api):
    """The console offers "Mark as rig model" from the job list: the list carries each job's
    stored results, as GET /jobs/{id} does."""
    from api_fixtures import drain

    r = api.client.post("/jobs", headers=api.h("operator"), json={
        "kind": "identification",
        "params": {"run_ids": [api.runs["fast"]], "model": "eq4", "method": "ls"}})
    assert r.status_code == 202, r.text
    drain(api)
    one = get(api, r.headers["location"])
    listed = next(j for j in get(api, "/jobs") if j["id"] == one["id"])
    assert one["state"] == "succeeded" and one["result_ids"]
    assert listed["result_ids"] == one["result_ids"]
