"""/jobs through HTTP and the durable queue: 202 + Location, Idempotency-Key, validation,
cancel, atomic claims across processes, a job run by a worker (results in SQL linked to their
runs, equal to a direct estimator call), a job that raises ends 'failed', the whole path with a
real worker process through to the job report, a worker killed mid-job (restarted by the
service's pool, the job re-queued and completed) and a service restarted after its worker died
unseen (the job re-queued at start-up). Crashing, stuck and cancelled jobs under supervision:
tests/test_api_job_supervision.py."""

from __future__ import annotations

import base64
import re
import signal
import subprocess
import sys
import time

import numpy as np
import pytest
from api_fixtures import api, drain, get  # noqa: F401  (api: fixture)


def ident(api, method="ls", model="eq4", **extra):
    return {"kind": "identification",
            "params": {"run_ids": [api.runs["fast"]], "model": model, "method": method, **extra}}


def post(api, body, key=None, role="operator"):
    h = api.h(role) | ({"Idempotency-Key": key} if key else {})
    return api.client.post("/jobs", json=body, headers=h)


def wait_state(api, jid, states, timeout_s=120.0, min_progress=None):
    deadline = time.monotonic() + timeout_s
    while time.monotonic() < deadline:
        j = get(api, f"/jobs/{jid}")
        if j["state"] in states and (min_progress is None or (j["progress"] or 0) >= min_progress):
            return j
        time.sleep(0.1)
    raise AssertionError(f"job {jid} did not reach {states}: {j}")


def test_submit_answers_202_with_location_and_validates(api):
    r = post(api, ident(api))
    assert r.status_code == 202
    job = r.json()
    assert r.headers["location"] == f"/jobs/{job['id']}" and job["state"] == "queued"
    again = get(api, r.headers["location"])
    assert again["id"] == job["id"] and again["kind"] == "identification"
    assert again["params"]["options"]["chains"] == 4          # defaults filled in, stored
    for bad in ({"kind": "nope", "params": {}},
                ident(api, method="magic"),
                ident(api, model="eq4; DROP TABLE runs"),
                ident(api, options={"draws": 10**9}),
                {"kind": "identification", "params": {"run_ids": [], "model": "eq4",
                                                      "method": "ls"}}):
        assert post(api, bad).status_code == 422, bad
    unknown = {"kind": "identification", "params": {"run_ids": [99999], "model": "eq4",
                                                    "method": "ls"}}
    assert post(api, unknown).status_code == 404
    assert api.client.get("/jobs/99999", headers=api.h("viewer")).status_code == 404
    drain(api)


def test_idempotency_key_returns_the_same_job(api):
    r1 = post(api, ident(api), key="retry-me-1")
    r2 = post(api, ident(api), key="retry-me-1")
    assert r1.status_code == 202 and r2.status_code == 200
    assert r1.json()["id"] == r2.json()["id"] and r2.headers["location"] == r1.headers["location"]
    assert post(api, ident(api, method="exact"), key="retry-me-1").status_code == 409
    other = post(api, ident(api), key="retry-me-2")
    assert other.status_code == 202 and other.json()["id"] != r1.json()["id"]
    drain(api)
    assert post(api, ident(api), key="retry-me-1").json()["state"] == "succeeded"


def test_cancel_a_queued_job_and_it_never_runs(api):
    jid = post(api, ident(api)).json()["id"]
    assert api.client.post(f"/jobs/{jid}/cancel", headers=api.h("viewer")).status_code == 403
    r = api.client.post(f"/jobs/{jid}/cancel", headers=api.h("operator"))
    assert r.status_code == 200 and r.json()["state"] == "cancelled"
    drain(api)
    j = get(api, f"/jobs/{jid}")
    assert j["state"] == "cancelled" and j["attempts"] == 0 and j["result_ids"] == []
    assert [x["id"] for x in get(api, "/jobs?state=cancelled")] == [jid]


def test_worker_runs_a_job_and_stores_results_linked_to_runs(api):
    from estimator.identify import identify

    jid = post(api, ident(api, test_run_ids=[api.runs["slow"]])).json()["id"]
    drain(api)
    j = get(api, f"/jobs/{jid}")
    assert j["state"] == "succeeded" and j["progress"] == 1.0 and j["attempts"] == 1
    assert j["timings"]["running_s"] > 0 and j["error"] is None and len(j["result_ids"]) == 1
    res = get(api, f"/jobs/{jid}/results")[0]
    assert {(x["run_id"], x["role"]) for x in res["runs"]} == {(api.runs["fast"], "train"),
                                                              (api.runs["slow"], "test")}
    direct = identify([api.store.load_run(api.runs["fast"])], "eq4", "ls",
                      [api.store.load_run(api.runs["slow"])])
    np.testing.assert_allclose([p["mean"] for p in res["fit"]["params"]], direct.mean, rtol=1e-12)
    used = get(api, f"/runs/{api.runs['slow']}")["results"]
    assert {"result_id": res["id"], "job_id": jid, "model": "eq4", "method": "ls",
            "role": "test"} in used
    assert any(r["job_id"] == jid for r in get(api, f"/reports/runs/{api.runs['fast']}")["results"])
    assert res["fit"]["rmse_test"] == pytest.approx(direct.rmse_test, rel=1e-12)


def test_a_job_that_raises_ends_failed_with_its_error(api):
    jid = post(api, ident(api, model="eq4+no_such_effect")).json()["id"]
    drain(api)
    j = get(api, f"/jobs/{jid}")
    assert j["state"] == "failed" and "no_such_effect" in j["error"] and j["result_ids"] == []
    assert j["finished_at"] is not None


CLAIMER = """
import sys
from db.jobs import claim
from db.store import Store
store = Store(sys.argv[1], upgrade=False, recover=False)
got = []
while (j := claim(store)) is not None:
    got.append(j["id"])
print(" ".join(map(str, got)))
"""


def test_two_worker_processes_never_claim_the_same_job(api):
    from db import jobs as queue
    ids = [queue.submit(api.store, "identification", {"run_ids": [api.runs["fast"]]})[0]["id"]
           for _ in range(40)]
    procs = [subprocess.Popen([sys.executable, "-c", CLAIMER, api.url], stdout=subprocess.PIPE,
                              text=True) for _ in range(2)]
    outs = [p.communicate(timeout=120)[0].split() for p in procs]
    a, b = ({int(x) for x in o} for o in outs)
    assert not a & b and a | b == set(ids)
    # these claimed jobs have no live worker: recovery fails them (max_attempts=1), never stuck
    lost = queue.recover_lost(api.store, max_attempts=1)
    assert set(ids) <= set(lost)
    for jid in ids:
        j = queue.get_job(api.store, jid)
        assert j["state"] == "failed" and "was lost" in j["error"] and "after 1 attempts" in j["error"]


def _imgs(html: str) -> dict[str, bytes]:
    return {k: base64.b64decode(v) for k, v in
            re.findall(r'<img alt="([a-z_0-9]+)" src="data:image/svg\+xml;base64,([^"]+)"', html)}


@pytest.mark.slow
def test_whole_path_with_a_worker_process_to_the_job_report(api):
    from api.worker import WorkerPool

    pool = WorkerPool(api.url, 1).start()
    try:
        r = post(api, ident(api, method="exact", options={"draws": 400}))
        sens = post(api, {"kind": "sensitivity", "params": {"run_ids": [api.runs["fast"]],
                                                            "n_base": 64,
                                                            "options": {"draws": 300}}})
        jid, sid = r.json()["id"], sens.json()["id"]
        j = wait_state(api, jid, ("succeeded", "failed"))
        assert j["state"] == "succeeded", j["error"]
        s = wait_state(api, sid, ("succeeded", "failed"))
        assert s["state"] == "succeeded", s["error"]
    finally:
        pool.stop()
    assert j["worker"].split("/")[1] != str(__import__("os").getpid())   # another process ran it
    rep = get(api, f"/reports/jobs/{jid}")
    assert rep["job"]["state"] == "succeeded" and "RMSE" in rep["tables"]
    html = api.client.get(f"/reports/jobs/{jid}/html", headers=api.h("viewer"))
    assert html.status_code == 200 and "Identification tables" in html.text
    imgs = _imgs(html.text)
    assert set(imgs) == {"predicted_vs_measured", "posterior", "corner", "rhat_trace", "autocorr"}
    assert all(b"<svg" in v and b"<path" in v for v in imgs.values())
    shtml = api.client.get(f"/reports/jobs/{sid}/html", headers=api.h("viewer")).text
    assert "sobol" in _imgs(shtml) and "Sobol indices" in shtml
    fit = get(api, f"/jobs/{sid}/results")[0]["fit"]
    assert fit["extra"]["sobol"]["name"] == [p["name"] for p in fit["params"]]
    assert all(0.0 <= x <= 1.05 for x in fit["extra"]["sobol"]["ST"])


@pytest.mark.slow
def test_worker_killed_mid_job_is_restarted_and_the_job_completes(api):
    from fastapi.testclient import TestClient

    from api.app import create_app
    from api.settings import Settings

    st = Settings(db_url=api.url, workers=1, max_body_bytes=64 * 1024)
    with TestClient(create_app(st)) as client:
        r = client.post("/jobs", json=ident(api, method="mh", options={"draws": 12000}),
                        headers=api.h("operator"))
        jid = r.json()["id"]
        wait_state(api, jid, ("running",), min_progress=0.2)       # inside the estimator
        proc = client.app.state.workers.procs[0]
        proc.send_signal(signal.SIGKILL)                           # the worker dies mid-job
        j = wait_state(api, jid, ("succeeded", "failed"), timeout_s=300)
        assert j["state"] == "succeeded", j["error"]
        assert j["attempts"] == 2 and len(j["result_ids"]) == 1
        h = client.get("/health", headers=api.h("viewer")).json()
        assert h["workers"]["restarts"] == 1 and h["status"] == "ok"
        assert "SIGKILL" in h["workers"]["processes"][0]["last_exit"]["cause"]
        assert h["workers"]["processes"][0]["last_exit"]["jobs"] == [jid]


@pytest.mark.slow
def test_service_killed_mid_job_requeues_and_completes_after_restart(api):
    from fastapi.testclient import TestClient

    from api.app import create_app
    from api.settings import Settings

    st = Settings(db_url=api.url, workers=1, max_body_bytes=64 * 1024)
    with TestClient(create_app(st)) as client:
        r = client.post("/jobs", json=ident(api, method="mh", options={"draws": 12000}),
                        headers=api.h("operator"))
        jid = r.json()["id"]
        j = wait_state(api, jid, ("running",), min_progress=0.2)   # inside the estimator
        pool = client.app.state.workers
        pool.stop_supervising()                                    # the service dies with it
        proc = pool.procs[0]
        proc.send_signal(signal.SIGKILL)                           # the worker dies mid-job
        proc.wait()
        assert get(api, f"/jobs/{jid}")["state"] == "running"      # nobody knows yet
    with TestClient(create_app(st)):                               # the service restarts
        j = get(api, f"/jobs/{jid}")          # re-queued at start-up, maybe claimed again
        assert (j["state"] == "queued" and j["attempts"] == 1 and "was lost" in j["error"]) \
            or (j["state"] in ("running", "succeeded") and j["attempts"] == 2), j
        j = wait_state(api, jid, ("succeeded", "failed"), timeout_s=300)
    assert j["state"] == "succeeded", j["error"]
    assert j["attempts"] == 2 and len(j["result_ids"]) == 1


@pytest.mark.slow
def test_cancel_a_running_job_discards_its_results(api):
    from api.worker import WorkerPool

    pool = WorkerPool(api.url, 1).start()
    try:
        slow = post(api, ident(api, method="mh", options={"draws": 12000})).json()["id"]
        wait_state(api, slow, ("running",), min_progress=0.2)
        r = api.client.post(f"/jobs/{slow}/cancel", headers=api.h("operator"))
        assert r.json()["state"] == "cancelled"
        quick = post(api, ident(api)).json()["id"]     # the one worker takes it after `slow`
        assert wait_state(api, quick, ("succeeded", "failed"))["state"] == "succeeded"
    finally:
        pool.stop()
    j = get(api, f"/jobs/{slow}")
    assert j["state"] == "cancelled" and j["result_ids"] == []
    assert get(api, f"/jobs/{slow}/results") == []
