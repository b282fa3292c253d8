"""Job report pages (every posterior, corner and diagnosis figure redrawn) are computed once per
service process while the job and its results' documents are unchanged, and never cached while
the job is queued or running."""

from __future__ import annotations

from api_fixtures import api, drain  # noqa: F401  (fixture)


def _job(api) -> int:
    body = {"kind": "identification",
            "params": {"run_ids": [api.runs["fast"]], "model": "eq4", "method": "ls"}}
    r = api.client.post("/jobs", json=body, headers=api.h("operator"))
    assert r.status_code == 202, r.text
    return r.json()["id"]


def test_job_report_is_drawn_once_per_version(api, monkeypatch):
    from datetime import datetime, timezone

    from api import reports
    from db.models import Report, Result

    calls: list[tuple[int, bool]] = []
    real = reports.job_report

    def counting(store, job_id, with_plots=True):
        calls.append((job_id, with_plots))
        return real(store, job_id, with_plots=with_plots)
    monkeypatch.setattr(reports, "job_report", counting)

    jid = _job(api)
    h = api.h("viewer")
    for _ in range(2):                                   # queued: recomputed each time
        assert api.client.get(f"/reports/jobs/{jid}", headers=h).json()["job"]["state"] == "queued"
    assert len(calls) == 2
    drain(api)
    calls.clear()
    pages = [api.client.get(f"/reports/jobs/{jid}/html", headers=h) for _ in range(3)]
    assert all(p.status_code == 200 for p in pages) and len({p.text for p in pages}) == 1
    assert "<svg" in pages[0].text or "data:image/svg+xml" in pages[0].text
    docs = [api.client.get(f"/reports/jobs/{jid}", headers=h).json() for _ in range(3)]
    assert docs[0]["job"]["state"] == "succeeded" and docs[0] == docs[2]
    assert calls == [(jid, True), (jid, False)]          # drawn once per form

    with api.store.Session.begin() as s:                 # a new document about its result
        res = s.query(Result.id).filter(Result.job_id == jid).first()[0]
        s.add(Report(kind="note", title="x", result_id=res, media_type="application/json",
                     content=b"{}", created_at=datetime.now(timezone.utc)))
    assert api.client.get(f"/reports/jobs/{jid}/html", headers=h).status_code == 200
    assert calls[-1] == (jid, True) and len(calls) == 3
    assert api.client.get("/reports/jobs/99999/html", headers=h).status_code == 404
