"""Fail safe, not open: the job workers under supervision (api.worker.WorkerPool) with real
worker processes. A job that kills its worker process (SIGKILL as from the out-of-memory
killer, os._exit as from a fatal error in compiled code) is re-queued once, then 'failed'
naming the crash, while the dead workers are restarted and a normal job still completes; a
job past its kind's wall-clock limit ends 'failed' with the limit in its reason, whether it
polls the stop check or sits in code that polls nothing; a cancel reaches a running sampler
and frees its worker within seconds; `GET /health` shows the restarts, and 'degraded' while no
worker serves the queue. The misbehaving kinds are test-only (tests/job_supervision_kinds.py).
Timing asserts are generous: the only bound is a wait far below what the work would take."""

from __future__ import annotations

import sys
import time
from contextlib import contextmanager

import pytest
from api_fixtures import _api, database, get
from job_supervision_kinds import TIME_LIMIT_S, worker_command

FINAL = ("succeeded", "failed", "cancelled")


@pytest.fixture(scope="module")
def sup(tmp_path_factory):
    # the test kinds exist in the worker processes only (worker_command), never in this
    # process's KINDS: the supervisor learns each job's limit from its worker
    with database("sqlite", tmp_path_factory) as url:
        yield from _api(url)


@contextmanager
def supervised(api, n: int, command: list[str] | None = None, **kw):
    """A WorkerPool of `n` worker processes knowing the test kinds, shown by /health."""
    from api.worker import WorkerPool

    pool = WorkerPool(api.url, n, command=command or worker_command(),
                      backoff_s=kw.pop("backoff_s", (0.2, 1.0)), **kw).start()
    api.client.app.state.workers = pool
    try:
        yield pool
    finally:
        api.client.app.state.workers = None
        pool.stop()


def submit(api, kind: str, params: dict) -> int:
    from db import jobs as queue
    return queue.submit(api.store, kind, params)[0]["id"]


def submit_ls(api) -> int:
    r = api.client.post("/jobs", json={"kind": "identification", "params": {
        "run_ids": [api.runs["fast"]], "model": "eq4", "method": "ls"}},
        headers=api.h("operator"))
    assert r.status_code == 202, r.text
    return r.json()["id"]


def wait_for(what, timeout_s: float = 120.0, every_s: float = 0.1):
    """what() until it returns something true; AssertionError with its last value after
    timeout_s."""
    deadline = time.monotonic() + timeout_s
    while True:
        got = what()
        if got:
            return got
        if time.monotonic() > deadline:
            raise AssertionError(f"gave up waiting: last {got!r}")
        time.sleep(every_s)


def final(api, jid: int, timeout_s: float = 120.0) -> dict:
    return wait_for(lambda: (j := get(api, f"/jobs/{jid}"))["state"] in FINAL and j, timeout_s)


def test_jobs_that_kill_their_worker_fail_after_two_attempts_and_the_queue_goes_on(sup):
    with supervised(sup, 2):
        killed = submit(sup, "crash", {"how": "sigkill"})
        exited = submit(sup, "crash", {"how": "exit"})
        ok = submit_ls(sup)
        assert final(sup, ok)["state"] == "succeeded"
        j = final(sup, killed)
        assert j["state"] == "failed" and j["attempts"] == 2 and j["result_ids"] == []
        assert "died while running the job" in j["error"] and "SIGKILL" in j["error"]
        assert "not re-queued" in j["error"]
        j = final(sup, exited)
        assert j["state"] == "failed" and j["attempts"] == 2
        assert "exited with status 3" in j["error"] and "not re-queued" in j["error"]
        # every dead worker was restarted: both alive again, four restarts, the causes shown
        h = wait_for(lambda: (x := get(sup, "/health"))["workers"]["alive"] == 2
                     and x["workers"]["restarts"] >= 4 and x, timeout_s=60)
        assert h["status"] == "ok" and h["queue"]["served"] is True
        causes = " ".join(p["last_exit"]["cause"] for p in h["workers"]["processes"]
                          if p["last_exit"])
        assert "SIGKILL" in causes or "exited with status 3" in causes


def test_health_is_degraded_while_no_worker_serves_the_queue(sup):
    assert get(sup, "/health")["workers"]["supervised"] is False   # no pool in this service
    dies = [sys.executable, "-c", "import sys; sys.exit(3)"]         # a worker that cannot start
    with supervised(sup, 1, command=dies, backoff_s=(600.0, 600.0)):
        h = wait_for(lambda: (x := get(sup, "/health"))["workers"]["processes"][0]["last_exit"]
                     and x)
        assert h["status"] == "degraded" and h["queue"]["served"] is False
        assert h["workers"]["alive"] == 0 and h["workers"]["configured"] == 1
        assert h["workers"]["processes"][0]["last_exit"]["cause"] == "exited with status 3"
    assert sup.client.get("/health").status_code == 401


def test_jobs_past_their_wall_clock_limit_fail_and_the_queue_goes_on(sup):
    with supervised(sup, 1, grace_s=1.0):
        spin = submit(sup, "spin", {"seconds": 120})      # polls the stop check
        stuck = submit(sup, "stuck", {"seconds": 600})    # polls nothing
        ok = submit_ls(sup)
        limit = f"wall-clock limit of {TIME_LIMIT_S:g} s"
        j = final(sup, spin, timeout_s=60)
        assert j["state"] == "failed" and limit in j["error"], j
        j = final(sup, stuck, timeout_s=60)
        assert j["state"] == "failed" and limit in j["error"], j
        assert "worker process was ended" in j["error"]
        assert final(sup, ok)["state"] == "succeeded"
        h = get(sup, "/health")
        assert h["workers"]["restarts"] >= 1
        assert any("did not stop" in (p["last_exit"] or {}).get("cause", "")
                   for p in h["workers"]["processes"])


def test_cancel_reaches_a_running_sampler_and_frees_its_worker(sup):
    # one MH chain of 400 000 iterations: a minute or more of sampling, polled every iteration
    body = {"kind": "identification", "params": {
        "run_ids": [sup.runs["fast"]], "model": "eq4", "method": "mh",
        "options": {"chains": 1, "draws": 200_000, "warmup": 200_000}}}
    with supervised(sup, 1) as pool:
        jid = sup.client.post("/jobs", json=body, headers=sup.h("operator")).json()["id"]
        wait_for(lambda: pool.stats()["busy"] == 1)
        wait_for(lambda: (get(sup, f"/jobs/{jid}")["progress"] or 0) >= 0.1)
        time.sleep(1.0)                                   # inside the chain by now
        r = sup.client.post(f"/jobs/{jid}/cancel", headers=sup.h("operator"))
        assert r.status_code == 200 and r.json()["state"] == "cancelled"
        wait_for(lambda: get(sup, "/health")["workers"]["busy"] == 0, timeout_s=20)
        assert pool.stats()["restarts"] == 0               # stopped by itself, not ended
        ok = submit_ls(sup)
        assert final(sup, ok, timeout_s=30)["state"] == "succeeded"
    j = get(sup, f"/jobs/{jid}")
    assert j["state"] == "cancelled" and j["result_ids"] == []


def test_the_time_limit_setting_stops_a_sampler_in_a_worker(sup):
    # RIG_JOB_TIME_LIMIT_S overrides every kind's limit; the MH chain polls the stop flag
    from api.worker import Worker

    jid = sup.client.post("/jobs", headers=sup.h("operator"), json={
        "kind": "identification", "params": {
            "run_ids": [sup.runs["fast"]], "model": "eq4", "method": "mh",
            "options": {"chains": 1, "draws": 200_000, "warmup": 200_000}}}).json()["id"]
    w = Worker(sup.url, time_limit_s=1.0)
    try:
        assert w.run_once() == jid
    finally:
        w.close()
    j = get(sup, f"/jobs/{jid}")
    assert j["state"] == "failed" and "wall-clock limit of 1 s" in j["error"], j
    assert j["result_ids"] == []


def test_a_pool_worker_ends_when_the_service_that_started_it_is_gone():
    """A worker whose service was killed (SIGKILL: no shutdown) must not live on as an orphan
    taking jobs no service supervises (api.worker.follow_parent)."""
    import os
    import signal
    import subprocess
    import sys
    import time

    code = ("import subprocess, sys, time\n"
            "p = subprocess.Popen([sys.executable, '-c', 'import os, time; "
            "import api.worker as w; w.follow_parent(os.getppid(), 0.05); time.sleep(60)'])\n"
            "print(p.pid, flush=True)\n"
            "time.sleep(60)\n")
    service = subprocess.Popen([sys.executable, "-c", code], stdout=subprocess.PIPE, text=True)
    worker = int(service.stdout.readline())

    def alive(pid: int) -> bool:
        try:
            with open(f"/proc/{pid}/status") as f:
                return "\nState:\tZ" not in f.read()
        except FileNotFoundError:
            return False
    try:
        time.sleep(0.5)
        assert alive(worker)                      # it lives while its service does
        service.send_signal(signal.SIGKILL)
        service.wait(timeout=10)
        end = time.monotonic() + 10.0
        while alive(worker) and time.monotonic() < end:
            time.sleep(0.05)
        assert not alive(worker), "the worker outlived its service"
    finally:
        for pid in (worker,):
            try:
                os.kill(pid, signal.SIGKILL)
            except ProcessLookupError:
                pass
