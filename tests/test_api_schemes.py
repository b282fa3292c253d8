"""/schemes and /acquisitions through HTTP: roles (401/403), validation; scheme 1 started on the
emulator through the API (the service's acquisition process starts `rig emulate` and `rig run`)
→ server-sent events with progress and the live channels → the run in /runs with `success` →
an identification job on it succeeds → its report renders; stop mid-run → make-safe, `abort`,
the stand-in stopped; e-stop mid-run (by a viewer) → `abort` with the e-stop reason; 409 on a
second start; the rig needs the rig-operator role; the service shutting down stops (makes safe)
its acquisition."""

from __future__ import annotations

import asyncio
import json
import os
import signal
import socket
import subprocess
import sys
import time

import pytest
from api_fixtures import wait_until_serving
from db_fixtures import empty_database
from drivers_harness import SLACK_ENV, SLACK_S, SLACK_STANDIN

SCALE = 5.0
SHORT = {"motor_speed_rpm": 3000.0, "load_target": 20e3, "ramp_rate": 10e3, "accel_time": 0.5,
         "settle_time": 0.5, "rest_time": 0.5, "sample_rate_hz": 20.0}
"""Scheme 1 of ~6 s of rig time (~1.2 s of wall time at SCALE)."""
LONG = {**SHORT, "load_target": 100e3, "ramp_rate": 2.5e3}
"""Scheme 1 of ~82 s of rig time (~16 s of wall time): stopped or e-stopped mid-run."""


@pytest.fixture(scope="module")
def api(tmp_path_factory):
    from fastapi.testclient import TestClient

    from api.app import create_app
    from api.settings import Settings
    from api_fixtures import Api
    from db.store import Store
    from db.tokens import create_token

    with pytest.MonkeyPatch.context() as mp, \
            empty_database("sqlite", tmp_path_factory.mktemp("schemes")) as url:
        for k, v in SLACK_ENV.items():
            mp.setenv(k, v)
        store = Store(url)
        tokens = {r: create_token(store, f"test-{r}", [r])
                  for r in ("viewer", "operator", "rig-operator", "admin")}
        app = create_app(Settings(db_url=url, workers=0, max_body_bytes=64 * 1024))
        with TestClient(app) as client:
            yield Api(client=client, url=url, store=store, runs={}, tokens=tokens)
        store.close()


def body(params=SHORT, **kw):
    return {"target": "emulator", "operator": "alice", "params": params,
            "emulator": {"time_scale": SCALE, "seed": 3, "watchdog_s": SLACK_S}, **kw}


def start(api, params=SHORT, scheme=1, **kw):
    r = api.client.post(f"/schemes/{scheme}/runs", json=body(params, **kw),
                        headers=api.h("operator"))
    assert r.status_code == 202, r.text
    assert r.headers["location"] == f"/acquisitions/{r.json()['id']}"
    return r.headers["location"]


def get(api, path):
    r = api.client.get(path, headers=api.h("viewer"))
    assert r.status_code == 200, r.text
    return r.json()


def wait(api, loc, cond, timeout=90.0):
    end = time.monotonic() + timeout
    while time.monotonic() < end:
        a = get(api, loc)
        if cond(a):
            return a
        assert a["state"] != "ended", f"{loc} ended before the condition: {a}"
        time.sleep(0.2)
    raise AssertionError(f"{loc} never met the condition: {a}")


def events(api, loc):
    """The acquisition's server-sent events until the stream ends: [(event, data)]."""
    out, ev = [], None
    with api.client.stream("GET", loc + "/events", headers=api.h("viewer")) as r:
        assert r.status_code == 200 and r.headers["content-type"].startswith("text/event-stream")
        for line in r.iter_lines():
            if line.startswith("event: "):
                ev = line[7:]
            elif line.startswith("data: "):
                out.append((ev, json.loads(line[6:])))
    return out


def port_closed(port: int) -> bool:
    with socket.socket() as s:
        return s.connect_ex(("127.0.0.1", port)) != 0


def pid_gone(pid: int) -> bool:
    try:
        os.kill(pid, 0)
    except ProcessLookupError:
        return True
    return False


def test_roles_and_validation(api):
    some = "0" * 32
    for method, path in (("post", "/schemes/1/runs"), ("post", "/schemes/3/runs"),
                         ("get", "/acquisitions"), ("get", f"/acquisitions/{some}"),
                         ("get", f"/acquisitions/{some}/events"),
                         ("post", f"/acquisitions/{some}/stop"),
                         ("post", f"/acquisitions/{some}/estop")):
        assert getattr(api.client, method)(path).status_code == 401, path
        bad = getattr(api.client, method)(path, headers={"Authorization": "Bearer nope"})
        assert bad.status_code == 401, path
    for path in ("/schemes/1/runs", "/schemes/2/runs", f"/acquisitions/{some}/stop"):
        assert api.client.post(path, json=body(), headers=api.h("viewer")).status_code == 403
    # the e-stop is every signed-in role's: a viewer's gets through (404: no such acquisition)
    assert api.client.post(f"/acquisitions/{some}/estop", json={"reason": "r"},
                           headers=api.h("viewer")).status_code == 404
    # the real rig needs the rig-operator role: viewer and operator are refused before anything
    # starts; a rig-operator's request is checked (this one's travel is refused: 422)
    for role in ("viewer", "operator"):
        r = api.client.post("/schemes/1/runs", json=body(target="rig"), headers=api.h(role))
        assert r.status_code == 403, (role, r.text)
    assert "rig-operator" in r.json()["detail"]
    r = api.client.post("/schemes/1/runs", headers=api.h("rig-operator"),
                        json=body({**SHORT, "ramp_rate": 100.0}, target="rig"))
    assert r.status_code == 422 and "180" in r.text, r.text
    r = api.client.post("/tokens", json={"name": "rig-hand", "role": "rig-operator"},
                        headers=api.h("admin"))
    assert r.status_code == 201 and r.json()["role"] == "rig-operator", r.text
    for path in (f"/acquisitions/{some}", f"/acquisitions/{some}/events"):
        assert api.client.get(path, headers=api.h("viewer")).status_code == 404
    assert api.client.get("/acquisitions/xyz", headers=api.h("viewer")).status_code == 422
    for bad in (body({**SHORT, "motor_speed_rpm": 5000.0}), body({**SHORT, "step": 1e3}),
                body(target="moon"), body(operator=""), body(operator="a\nb"),
                body({**SHORT, "sample_rate_hz": 50.0}),            # 50 Hz × 5 > the poll
                body({**SHORT, "motor_speed_rpm": 3000.0, "ramp_rate": 100.0}),  # > ±180°
                {**body(), "emulator": {"time_scale": 1000.0}},
                {**body(), "emulator": {"effects": {"no_such_effect": {}}}}):
        r = api.client.post("/schemes/1/runs", json=bad, headers=api.h("operator"))
        assert r.status_code == 422, (bad, r.text)
    assert get(api, "/acquisitions") == []                  # nothing was started


def test_scheme1_on_the_emulator_to_an_identification_report(api):
    from api.worker import Worker

    loc = start(api, SHORT)
    evs = events(api, loc)
    kinds = [e for e, _ in evs]
    assert kinds[0] == "state" and kinds[-1] == "end"
    states = [d["state"] for e, d in evs if e == "state"]
    assert states[0] == "starting" and "running" in states and states[-1] == "ended"
    prog = [d for e, d in evs if e == "progress"]
    assert len(prog) >= 2
    fr = [p["fraction"] for p in prog]
    assert fr == sorted(fr) and 0.0 <= fr[0] < 1.0 and fr[-1] > 0.3
    assert {p["phase"] for p in prog if p["n_samples"]} <= {"idle", "load", "unload"}
    assert all(p["phase"] is None for p in prog if not p["n_samples"])
    assert any(p["phase"] == "load" for p in prog)
    live = prog[-1]["channels"]
    assert {"q", "torque", "torque_load", "i_m1", "w_m1", "p_hyd"} <= set(live)
    assert any(abs(p["channels"].get("torque_load") or 0.0) > 1e3 for p in prog)  # loading seen
    end = evs[-1][1]
    assert end["state"] == "ended" and end["run_status"] == "success", end
    rid = end["run_id"]
    assert rid is not None and all(p["run_id"] == rid for p in prog)
    assert end["standin"]["running"] is False and pid_gone(end["standin"]["pid"])

    run = next(r for r in get(api, "/runs") if r["id"] == rid)
    assert (run["status"], run["exit_status"], run["source"]) == ("finished", "success",
                                                                   "emulator")
    assert run["scheme"] == 1 and run["n_samples"] > 80
    detail = get(api, f"/runs/{rid}")
    assert detail["meta"]["operator"] == "alice"
    assert detail["meta"]["scheme_params"]["load_target"] == 20e3

    job = api.client.post("/jobs", json={"kind": "identification", "params": {
        "run_ids": [rid], "model": "eq4", "method": "exact",
        "options": {"chains": 2, "draws": 200}}},
        headers=api.h("operator"))
    assert job.status_code == 202, job.text
    w = Worker(api.url)
    while w.run_once() is not None:
        pass
    w.store.close()
    j = get(api, job.headers["location"])
    assert j["state"] == "succeeded", j["error"]
    html = api.client.get(f"/reports/jobs/{j['id']}/html", headers=api.h("viewer"))
    assert html.status_code == 200 and "Identification tables" in html.text
    assert html.text.count('src="data:image/svg+xml;base64,') >= 3


def test_stop_mid_run_makes_safe_aborts_and_stops_the_standin(api):
    loc = start(api, LONG)
    a = wait(api, loc, lambda a: a["state"] == "running" and (a["progress"] or {}).get(
        "n_samples", 0) >= 20)
    assert a["standin"]["running"] and not port_closed(a["standin"]["plc_port"])
    # one acquisition at a time on a target
    again = api.client.post("/schemes/2/runs", json=body({"load_target": 20e3}),
                            headers=api.h("operator"))
    assert again.status_code == 409 and a["id"] in again.json()["detail"]
    r = api.client.post(loc + "/stop", headers=api.h("operator"))
    assert r.status_code == 200 and r.json()["state"] in ("stopping", "ended")
    a = wait(api, loc, lambda a: a["state"] == "ended")
    assert a["run_status"] == "abort" and a["reason"] == "cancelled by the operator", a
    assert a["requests"][0]["command"] == "stop" and a["requests"][0]["by"] == "test-operator"
    assert a["progress"]["fraction"] < 0.9
    info = get(api, f"/runs/{a['run_id']}")
    assert (info["status"], info["exit_status"]) == ("finished", "abort")
    made_safe = [e for e in info["meta"]["end"]["events"] if e["kind"] == "make_safe"]
    assert made_safe and "abort" in made_safe[-1]["message"]
    assert info["meta"]["end"]["after_make_safe"] == "pump off, valve locked, run request cleared"
    assert a["standin"]["running"] is False and a["standin"]["exit_code"] == 0
    assert pid_gone(a["standin"]["pid"]) and port_closed(a["standin"]["plc_port"])
    # a stopped acquisition does not block the next one; stopping it again is harmless
    assert api.client.post(loc + "/stop", headers=api.h("operator")).json()["state"] == "ended"


def test_estop_mid_run_on_the_rig_aborts_with_the_estop_reason(api, monkeypatch):
    """Target 'rig': the rig of the DAQ settings (here a stand-in this test starts, named by
    RIG_* variables as a real rig would be) — the same code path without a service stand-in."""
    from simulators.process import StandinProcess

    with StandinProcess([f"--time-scale={SCALE}", "--seed=5", *SLACK_STANDIN]) as rig:
        monkeypatch.delenv("RIG_CONFIG", raising=False)
        for k, v in (("RIG_PLC_PORT", rig.plc_port), ("RIG_CAN_PORT", rig.can_port),
                     ("RIG_PLC_POLL_HZ", 200), ("RIG_TPDO_RATE_HZ", 100)):
            monkeypatch.setenv(k, str(v))
        r = api.client.post("/schemes/1/runs", json=body(LONG, target="rig"),
                            headers=api.h("rig-operator"))
        assert r.status_code == 202, r.text
        loc = r.headers["location"]
        a = wait(api, loc, lambda a: a["state"] == "running" and (a["progress"] or {}).get(
            "n_samples", 0) >= 10)
        assert a["target"] == "rig" and a["standin"] is None
        r = api.client.post(loc + "/estop", json={"reason": "smoke at the gearbox"},
                            headers=api.h("viewer"))            # anyone signed in may e-stop
        assert r.status_code == 200
        a = wait(api, loc, lambda a: a["state"] == "ended")
        assert a["run_status"] == "abort", a
        assert a["reason"].startswith("interlock estop: operator e-stop: smoke at the gearbox"), a
        assert a["requests"][0] == {"command": "estop", "by": "test-viewer",
                                    "at": a["requests"][0]["at"]}
        info = get(api, f"/runs/{a['run_id']}")
        assert info["source"] == "rig" and info["meta"]["operator"] == "alice"
        assert any(i["kind"] == "interlock" and "smoke at the gearbox" in i["reason"]
                   for i in info["interruptions"])
        assert rig.proc.poll() is None            # the service never stops a rig it did not start
        # the rig's PLC holds the e-stop latched after the run
        st = asyncio.run(plc_status(rig.plc_port))
        from core.plc_map import REGISTER_MAP
        assert st["fault_code"] == 2
        assert int(st["status_bits"]) & REGISTER_MAP.signals["status_bits"].bit("estop")


async def plc_status(port: int) -> dict:
    from daq.plc import PlcClient
    from daq.settings import Settings
    c = PlcClient(Settings(plc_port=port))
    await c.connect()
    try:
        return await c.read_status()
    finally:
        c.close()


def test_service_shutdown_stops_its_acquisition(api):
    from fastapi.testclient import TestClient

    from api.app import create_app
    from api.settings import Settings

    app = create_app(Settings(db_url=api.url, workers=0))
    with TestClient(app) as client:
        r = client.post("/schemes/1/runs", json=body(LONG), headers=api.h("operator"))
        assert r.status_code == 202, r.text
        loc = r.headers["location"]
        end = time.monotonic() + 90
        while time.monotonic() < end:
            a = client.get(loc, headers=api.h("viewer")).json()
            if a["state"] == "running" and a["progress"]["n_samples"] >= 10:
                break
            assert a["state"] != "ended", a
            time.sleep(0.05)
        acq = app.state.acquisitions.get(a["id"])
    # the service is down: its acquisition was stopped and made safe before it went
    assert acq.state == "ended" and acq.run_status == "abort", acq.snapshot()
    assert acq.proc.poll() is not None and pid_gone(acq.standin["pid"])
    info = api.store.run_info(acq.run_id)
    assert (info["status"], info["exit_status"]) == ("finished", "abort")
    assert info["reason"] == "the service shut down", info["reason"]


def test_estop_of_a_wedged_acquisition_latches_the_plc_estop_and_kills_it(api):
    loc = start(api, LONG)
    a = wait(api, loc, lambda a: a["state"] == "running" and (a["progress"] or {}).get(
        "n_samples", 0) >= 10)
    acq = api.client.app.state.acquisitions.get(a["id"])
    os.kill(acq.rig_run_pid, signal.SIGSTOP)            # `rig run` hangs: commands go unheard
    r = api.client.post(loc + "/estop", json={"reason": "wedged"}, headers=api.h("operator"))
    assert r.status_code == 200
    a = wait(api, loc, lambda a: a["state"] == "ended")
    assert "PLC e-stop latched by the acquisition process" in a["log_tail"], a
    assert "stand-in: PLC trip: service e-stop" in a["log_tail"], a
    # the killed writer's run is marked interrupted at once, never left 'running'
    assert a["run_status"] == "interrupted" and "ended without stopping the run" in a["reason"]
    assert pid_gone(acq.rig_run_pid) and pid_gone(a["standin"]["pid"])


def test_service_killed_mid_run_its_acquisition_makes_safe_and_ends(api, tmp_path):
    import httpx

    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        port = s.getsockname()[1]
    env = {**os.environ, "RIG_DB_URL": api.url, "RIG_API_HOST": "127.0.0.1",
           "RIG_API_PORT": str(port)}
    log = open(tmp_path / "serve.log", "w")
    proc = subprocess.Popen([sys.executable, "-m", "commands.cli", "serve", "--workers", "0"],
                            env=env, stdout=log, stderr=subprocess.STDOUT)
    base, h = f"http://127.0.0.1:{port}", api.h("operator")
    try:
        wait_until_serving(base, proc)
        r = httpx.post(f"{base}/schemes/1/runs", json=body(LONG), headers=h)
        assert r.status_code == 202, r.text
        deadline = time.monotonic() + 60
        while (a := httpx.get(base + r.headers["location"], headers=h).json())["state"] \
                != "running" or a["progress"]["n_samples"] < 10:
            assert time.monotonic() < deadline and a["state"] != "ended", a
            time.sleep(0.05)
    finally:
        proc.kill()                                     # no shutdown, no clean-up
        proc.wait(timeout=10)
        log.close()
    deadline = time.monotonic() + 60
    while api.store.run_info(a["run_id"])["status"] == "running" or not (
            pid_gone(a["standin"]["pid"]) and port_closed(a["standin"]["plc_port"])):
        assert time.monotonic() < deadline, api.store.run_info(a["run_id"])
        time.sleep(0.1)
    info = api.store.run_info(a["run_id"])
    assert (info["status"], info["exit_status"]) == ("finished", "abort"), info
    # the record says why: the service went, not an operator
    assert info["reason"] == "the service is gone (end of the acquisition's input)", info["reason"]
    assert info["meta"]["end"]["after_make_safe"] == "pump off, valve locked, run request cleared"
