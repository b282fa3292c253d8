"""api/response_cache.py and its use by the routers: answers of finished runs are computed once
per process, recomputed when the run or what refers to it changes, never cached for a run still
being written; concurrent misses compute once; the memory budget holds."""

from __future__ import annotations

import threading
import time

import numpy as np
import pytest
from api_fixtures import api  # noqa: F401  (fixture)

from api.response_cache import ResponseCache, approx_size, cache_budget_bytes


# --- the cache itself ---------------------------------------------------------------------------

def test_concurrent_misses_compute_once():
    cache, calls, release = ResponseCache(1 << 20), [], threading.Event()

    def compute():
        calls.append(1)
        release.wait(10)
        return {"value": 42}

    got: list = []
    threads = [threading.Thread(target=lambda: got.append(cache.get_or_compute("k", compute)))
               for _ in range(8)]
    for t in threads:
        t.start()
    time.sleep(0.2)                # let every thread reach the cache while compute() is held
    release.set()
    for t in threads:
        t.join(10)
    assert len(calls) == 1 and len(got) == 8 and all(g is got[0] for g in got)
    assert cache.hits == 7 and cache.misses == 1


def test_budget_evicts_least_recently_used_and_zero_turns_it_off():
    cache = ResponseCache(max_bytes=300)
    for k in "abc":
        cache.get_or_compute(k, lambda k=k: k, size_of=lambda v: 100)
    cache.get_or_compute("a", lambda: pytest.fail("a is cached"), size_of=lambda v: 100)
    cache.get_or_compute("d", lambda: "d", size_of=lambda v: 100)     # evicts b, the oldest use
    assert len(cache) == 3 and cache.nbytes == 300
    assert cache.get_or_compute("b", lambda: "b2", size_of=lambda v: 100) == "b2"
    assert cache.get_or_compute("big", lambda: "x", size_of=lambda v: 301) == "x"  # too big: not kept
    assert cache.get_or_compute("big", lambda: "y", size_of=lambda v: 301) == "y"

    off, calls = ResponseCache(0), []
    for _ in range(3):
        off.get_or_compute("k", lambda: calls.append(1) or len(calls))
    assert len(calls) == 3 and len(off) == 0


def test_a_failed_compute_is_not_cached():
    cache = ResponseCache(1 << 20)
    with pytest.raises(RuntimeError):
        cache.get_or_compute("k", lambda: (_ for _ in ()).throw(RuntimeError("boom")))
    assert cache.get_or_compute("k", lambda: 1) == 1


def test_budget_from_environment(monkeypatch):
    monkeypatch.setenv("RIG_API_CACHE_MB", "0.5")
    assert cache_budget_bytes() == 512 * 1024
    monkeypatch.setenv("RIG_API_CACHE_MB", "-1")
    with pytest.raises(ValueError):
        cache_budget_bytes()
    assert approx_size({"a": [1.0, "xyz"]}) > approx_size({})


# --- through the API --------------------------------------------------------------------------

def _get(api, path, **params):
    r = api.client.get(path, headers=api.h("viewer"), params=params)
    assert r.status_code == 200, r.text
    return r.json()


def test_aggregates_of_a_finished_run_are_computed_once(api, monkeypatch):
    from db.store import Store

    calls: list[int] = []
    real = Store.phase_aggregates

    def counting(self, run_id, by_phase=True):
        calls.append(run_id)
        return real(self, run_id, by_phase=by_phase)

    monkeypatch.setattr(Store, "phase_aggregates", counting)
    rid = api.runs["slow"]
    first = _get(api, f"/runs/{rid}/aggregates")
    again = [_get(api, f"/runs/{rid}/aggregates") for _ in range(3)]
    assert all(a == first for a in again) and len(calls) <= 1   # once (or cached by an earlier test)
    whole = _get(api, f"/runs/{rid}/aggregates", by_phase=False)  # another answer, its own entry
    assert {r["phase"] for r in whole} == {None} and whole != first


def test_a_run_being_written_is_never_cached(api, monkeypatch):
    from db.store import Store
    from db.writer import RunWriter

    calls: list[int] = []
    real = Store.phase_aggregates
    monkeypatch.setattr(Store, "phase_aggregates",
                        lambda self, run_id, by_phase=True: calls.append(run_id)
                        or real(self, run_id, by_phase=by_phase))
    w = RunWriter(api.store)
    rid = w.start({"scheme": 1, "source": "emulator", "rig": "cache-test"}, ["t", "q", "phase"])
    try:
        w.append({"t": np.arange(100) * 0.01, "q": np.arange(100.0), "phase": ["load"] * 100})
        w.flush()
        rows = _get(api, f"/runs/{rid}/aggregates")
        assert [r["count"] for r in rows if r["channel"] == "q"] == [100]
        w.append({"t": 1 + np.arange(50) * 0.01, "q": np.arange(50.0), "phase": ["hold"] * 50})
        w.flush()
        rows = _get(api, f"/runs/{rid}/aggregates")                 # the new samples show
        assert sorted(r["count"] for r in rows if r["channel"] == "q") == [50, 100]
        assert len(calls) == 2
    finally:
        w.stop("success")
    _get(api, f"/runs/{rid}/aggregates")
    _get(api, f"/runs/{rid}/aggregates")
    assert len(calls) == 3                                          # finished: once more, then cached


def test_report_follows_new_results_and_metadata(api):
    from db.models import Job, Result, ResultRun, utcnow

    rid = api.runs["fast"]
    before = _get(api, f"/reports/runs/{rid}")
    page0 = api.client.get(f"/reports/runs/{rid}/html", headers=api.h("viewer")).text
    assert _get(api, f"/reports/runs/{rid}") == before               # served again, unchanged

    with api.store.Session.begin() as s:
        job = Job(kind="identification", status="succeeded", params={}, run_id=rid,
                  created_at=utcnow())
        s.add(job)
        s.flush()
        res = Result(job_id=job.id, model="eq4", method="cache-test", fit={}, created_at=utcnow())
        s.add(res)
        s.flush()
        s.add(ResultRun(result_id=res.id, run_id=rid, role="train"))
        new_id = res.id
    after = _get(api, f"/reports/runs/{rid}")
    assert new_id in [r["result_id"] for r in after["results"]]
    assert new_id not in [r["result_id"] for r in before["results"]]
    page1 = api.client.get(f"/reports/runs/{rid}/html", headers=api.h("viewer")).text
    assert "cache-test" in page1 and "cache-test" not in page0

    api.store.update_run_meta(rid, {"notes": "re-checked by the cache test"})
    assert _get(api, f"/reports/runs/{rid}")["run"]["meta"]["notes"] == "re-checked by the cache test"
    assert api.client.get("/reports/runs/99999", headers=api.h("viewer")).status_code == 404
