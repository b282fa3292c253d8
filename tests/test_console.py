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


# --- the live view's rig state: PLC, drives, interlocks, e-stop latch in every progress event ---

def _check_typed(value, typ, where: str = "rig") -> None:
    """Assert that the JSON `value` has the shape of the TypedDict (or type) `typ`: every key
    the TypedDict declares, no other, each of its declared type (recursively)."""
    import typing

    origin, args = typing.get_origin(typ), typing.get_args(typ)
    if typing.is_typeddict(typ):
        hints = typing.get_type_hints(typ)
        assert isinstance(value, dict) and set(value) == set(hints), (where, value)
        for k, t in hints.items():
            _check_typed(value[k], t, f"{where}.{k}")
    elif origin in (typing.Union, __import__("types").UnionType):
        errors = []
        for t in args:
            try:
                return _check_typed(value, t, where)
            except AssertionError as exc:
                errors.append(exc)
        raise AssertionError(f"{where}: {value!r} is none of {args}")
    elif origin is list:
        assert isinstance(value, list), (where, value)
        for k, v in enumerate(value):
            _check_typed(v, args[0], f"{where}[{k}]")
    elif origin is dict:
        assert isinstance(value, dict), (where, value)
        for k, v in value.items():
            _check_typed(k, args[0], f"{where} key")
            _check_typed(v, args[1], f"{where}.{k}")
    elif typ is type(None):
        assert value is None, (where, value)
    elif typ is float:
        assert isinstance(value, (int, float)) and not isinstance(value, bool), (where, value)
    elif typ is int:
        assert isinstance(value, int) and not isinstance(value, bool), (where, value)
    else:
        assert isinstance(value, typ), (where, value, typ)


def test_rig_state_is_read_from_what_the_rig_holds():
    """daq.engine.rig_state names the PLC mode, fault and status bits of the latest poll, each
    drive's CiA 402 state, the latched trips and the e-stop latch; no device is touched (the
    rig is not even started)."""
    from core.documents import RigState
    from core.drive_od import statusword_for
    from core.plc_map import REGISTER_MAP
    from daq.drives import Drive
    from daq.engine import rig_state
    from daq.interlocks import INTERLOCKS, Interlocks
    from daq.rig import Rig
    from daq.settings import Settings

    rig = Rig(Settings(node_ids=(1, 2, 3)))
    rig.drives.drives = [Drive(n, n, node=None) for n in (1, 2, 3)]   # as DriveMaster.open does
    before = rig_state(rig)
    _check_typed(before, RigState)
    assert before["plc"]["mode"] == "unknown" and before["plc"]["link"] is False
    assert [i["name"] for i in before["interlocks"]] == list(INTERLOCKS)
    assert not any(i["tripped"] for i in before["interlocks"]) and not before["estop_latched"]
    assert [d["state"] for d in before["drives"]] == ["UNKNOWN"] * 3

    bit = REGISTER_MAP.signals["status_bits"].bit
    rig.last_status = {"plc_mode": 2.0, "fault_code": 0.0,
                       "status_bits": float(bit("pump_running") | bit("homed"))}
    d1, d2, d3 = rig.drives.drives
    d1.statusword = statusword_for("OPERATION ENABLED")
    d2.statusword = statusword_for("FAULT")
    d3.statusword = statusword_for("OPERATION ENABLED")
    d3.active, d3.dropped_reason = False, "heartbeat lost (2.1 s)"
    d1.temperature = 41.5
    running = rig_state(rig)
    _check_typed(running, RigState)
    plc = running["plc"]
    assert (plc["mode"], plc["mode_code"], plc["fault"]) == ("run", 2, "none")
    assert plc["bits"]["pump_running"] and plc["bits"]["homed"] and not plc["bits"]["estop"]
    assert [(d["enabled"], d["fault"], d["active"]) for d in running["drives"]] == [
        (True, False, True), (False, True, True), (False, False, False)]
    assert running["drives"][0]["temperature"] == 41.5
    assert running["drives"][2]["dropped_reason"] == "heartbeat lost (2.1 s)"

    rig.trips.append(Interlocks.operator_estop("smoke at the gearbox"))
    rig.safe = True
    rig.last_status = {**rig.last_status, "plc_mode": 3.0, "fault_code": 2.0,
                       "status_bits": float(bit("estop") | bit("safe_state"))}
    stopped = rig_state(rig)
    assert stopped["estop_latched"] and stopped["safe"]
    assert "smoke at the gearbox" in stopped["estop_reason"]
    assert (stopped["plc"]["mode"], stopped["plc"]["fault"]) == ("safe", "e-stop")
    tripped = {i["name"]: i for i in stopped["interlocks"] if i["tripped"]}
    assert list(tripped) == ["estop"] and "smoke" in tripped["estop"]["message"]


def test_the_event_stream_sends_every_progress_event():
    """Two progress events that arrive between two wake-ups of the event stream are both
    sent (none merged); a client that connects gets the latest one (the last known state)."""
    import json

    from api.acquisition import Acquisition, AcquisitionManager
    from api.routers.schemes import _progress_since

    mgr = AcquisitionManager("sqlite://", store=None)
    acq = Acquisition(id="0" * 32, spec=None)
    for k in range(3):
        mgr._bump(acq, progress={"t": 0.1 * k})
    assert acq.progress_seq == 3 and acq.progress == {"t": 0.2}
    assert [json.loads(p)["t"] for _, p in _progress_since(acq, -1)] == [0.2]
    assert [(n, json.loads(p)) for n, p in _progress_since(acq, 1)] == [
        (2, {"run_id": None, "t": 0.1}), (3, {"run_id": None, "t": 0.2})]
    assert _progress_since(acq, 3) == []


def test_progress_events_carry_the_rig_state_and_the_estop_latch(api, monkeypatch):
    """Scheme 1 on the emulator through the API: every progress event of the event stream
    carries the rig's state typed as core.documents.RigState (PLC running, drives enabled, no
    interlock tripped); after an e-stop the last one shows the latch and the estop trip, and
    the ended acquisition keeps it as the last known state."""
    import json
    import threading

    from core.documents import RigState
    from drivers_harness import SLACK_ENV, SLACK_S

    for k, v in SLACK_ENV.items():
        monkeypatch.setenv(k, v)
    params = {"motor_speed_rpm": 3000.0, "load_target": 100e3, "ramp_rate": 2.5e3,
              "accel_time": 0.5, "settle_time": 0.5, "rest_time": 0.5, "sample_rate_hz": 20.0}
    r = api.client.post("/schemes/1/runs", headers=api.h("operator"), json={
        "target": "emulator", "operator": "alice", "params": params,
        "emulator": {"time_scale": 5.0, "seed": 3, "watchdog_s": SLACK_S}})
    assert r.status_code == 202, r.text
    loc = r.headers["location"]
    evs: list = []

    def read() -> None:
        ev = None
        with api.client.stream("GET", loc + "/events", headers=api.h("viewer")) as s:
            for line in s.iter_lines():
                if line.startswith("event: "):
                    ev = line[7:]
                elif line.startswith("data: "):
                    evs.append((ev, json.loads(line[6:])))
    reader = threading.Thread(target=read, daemon=True)
    reader.start()
    deadline = time.monotonic() + 120
    while sum(e == "progress" for e, _ in evs) < 5:
        assert time.monotonic() < deadline and reader.is_alive(), evs[-3:]
        time.sleep(0.1)
    assert api.client.post(loc + "/estop", headers=api.h("viewer"),
                           json={"reason": "smoke at the gearbox"}).status_code == 200
    reader.join(timeout=120)
    assert not reader.is_alive() and evs[-1][0] == "end", evs[-3:]
    progress = [d for e, d in evs if e == "progress"]
    for p in progress:
        _check_typed(p["rig"], RigState)
        assert [i["name"] for i in p["rig"]["interlocks"]][:3] == ["torque", "bending", "shear"]
    first = progress[0]["rig"]
    assert first["plc"]["link"] and first["plc"]["mode"] in ("ready", "run")
    assert [d["motor"] for d in first["drives"]] == [1, 2, 3]
    assert all(d["enabled"] and d["state"] == "OPERATION ENABLED" for d in first["drives"])
    assert not first["estop_latched"] and not any(i["tripped"] for i in first["interlocks"])
    last = progress[-1]["rig"]
    assert last["estop_latched"] and last["safe"] and "smoke at the gearbox" in last["estop_reason"]
    assert {i["name"] for i in last["interlocks"] if i["tripped"]} == {"estop"}
    ended = evs[-1][1]
    assert ended["run_status"] == "abort" and ended["progress"]["rig"] == last
