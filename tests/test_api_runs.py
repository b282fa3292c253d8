"""/runs through HTTP: list and filters, detail, channel data with time range and decimation,
per-phase aggregates (checked against numpy on the loaded run), acceptance indicators, and the
run report (JSON and HTML with its SVG plots)."""

from __future__ import annotations

import base64
import re

import numpy as np
import pytest
from api_fixtures import api  # noqa: F401  (fixture)


def _get(api, path, **params):
    r = api.client.get(path, params=params, headers=api.h("viewer"))
    assert r.status_code == 200, r.text
    return r.json()


def test_list_and_filter_runs(api):
    fast, slow = api.runs["fast"], api.runs["slow"]
    ids = lambda **kw: [r["id"] for r in _get(api, "/runs", **kw)]  # noqa: E731
    assert ids() == [slow, fast]                                     # newest first
    assert ids(scheme=1) == [slow, fast] and ids(scheme=2) == []
    assert ids(speed=3000) == [fast] and ids(speed=300) == [slow]
    assert ids(direction=-1) == [slow] and ids(direction=1) == [fast]
    assert ids(rig="J4-emulator") == [slow, fast] and ids(rig="other") == []
    assert ids(status="finished") == [slow, fast] and ids(status="interrupted") == []
    assert ids(started_after="2026-02-01T00:00:00Z") == [slow]
    assert ids(started_before="2026-02-01T00:00:00Z") == [fast]
    assert ids(limit=1) == [slow] and ids(limit=1, offset=1) == [fast]
    row = _get(api, "/runs", speed=300)[0]
    assert row["motor_speed_rpm"] == 300 and row["direction"] == -1 and row["source"] == "emulator"
    r = api.client.get("/runs", params={"direction": 2}, headers=api.h("viewer"))
    assert r.status_code == 422


def test_run_detail_and_404(api):
    d = _get(api, f"/runs/{api.runs['fast']}")
    run = api.store.load_run(api.runs["fast"])
    assert d["n_samples"] == len(run.samples) and d["exit_status"] == "success"
    assert [c["name"] for c in d["channels"]] == list(run.samples.columns)
    assert {c["name"]: c["unit"] for c in d["channels"]}["torque"] == "N·m"
    assert d["meta"]["motor_speed_rpm"] == 3000
    assert api.client.get("/runs/99999", headers=api.h("viewer")).status_code == 404


def test_run_detail_lists_are_paged_with_their_totals(api):
    rid = api.runs["fast"]
    names = list(api.store.load_run(rid).samples.columns)
    d = _get(api, f"/runs/{rid}")
    assert d["totals"] == {"channels": len(names), "interruptions": len(d["interruptions"]),
                           "results": len(d["results"])}
    page = _get(api, f"/runs/{rid}", limit=3, offset=2)
    assert [c["name"] for c in page["channels"]] == names[2:5]
    assert page["totals"] == d["totals"] and page["n_samples"] == d["n_samples"]
    assert _get(api, f"/runs/{rid}", offset=len(names))["channels"] == []
    r = api.client.get(f"/runs/{rid}", params={"limit": 10**6}, headers=api.h("viewer"))
    assert r.status_code == 422


def test_channel_data_time_range_and_decimation(api):
    rid = api.runs["fast"]
    arr = api.store.load_arrays(rid, ["t", "torque", "phase"])
    d = _get(api, f"/runs/{rid}/data", channels="torque,phase", t_start=10.0, t_end=20.0, every=3)
    sel = np.flatnonzero((arr["t"] >= 10.0) & (arr["t"] <= 20.0))[::3]
    assert set(d["channels"]) == {"t", "torque", "phase"}
    assert d["n"] == sel.size and d["every"] == 3 and d["capped"] is False
    assert d["n_in_range"] == int(((arr["t"] >= 10.0) & (arr["t"] <= 20.0)).sum())
    np.testing.assert_array_equal(d["channels"]["t"], arr["t"][sel])
    np.testing.assert_allclose(d["channels"]["torque"], arr["torque"][sel])
    assert d["channels"]["phase"] == list(arr["phase"][sel])
    d = _get(api, f"/runs/{rid}/data", channels="q", max_points=100)   # decimated to the cap
    assert d["n"] <= 100 and d["every"] == int(np.ceil(arr["t"].size / 100))
    assert d["capped"] is True and d["max_points"] == 100 and d["n_in_range"] == arr["t"].size
    r = api.client.get(f"/runs/{rid}/data", params={"channels": "nope"}, headers=api.h("viewer"))
    assert r.status_code == 404 and "nope" in r.json()["detail"]


def test_channel_data_reads_only_the_pages_of_the_range(api, monkeypatch):
    """A narrow time range of one channel fetches the blocks of the one or two pages holding
    it (the time channel to cut the range, then time and the channel), never the whole run."""
    import db.store

    rid = api.runs["fast"]
    info = api.store.run_info(rid)
    fetched: list[tuple[int, int]] = []
    real = db.store.fetch_page_blocks

    def counting(conn, run_id, channel_ids, seqs):
        rows = real(conn, run_id, channel_ids, seqs)
        fetched.extend((r[0], r[1]) for r in rows)
        return rows
    monkeypatch.setattr(db.store, "fetch_page_blocks", counting)
    loads = []
    monkeypatch.setattr(type(api.store), "load_arrays",
                        lambda *a, **k: loads.append(a) or pytest.fail("whole-run load"))
    t_mid = info["t_last"] / 2
    d = _get(api, f"/runs/{rid}/data", channels="torque", t_start=t_mid, t_end=t_mid + 0.05)
    assert d["n"] > 0 and d["capped"] is False and set(d["channels"]) == {"t", "torque"}
    assert all(t_mid <= t <= t_mid + 0.05 for t in d["channels"]["t"])
    seqs = {seq for _, seq in fetched}
    assert 1 <= len(seqs) <= 2 and len(fetched) <= 3 * len(seqs)
    assert len(fetched) < info["n_pages"] * 2 and not loads


def test_phase_aggregates_match_numpy(api):
    rid = api.runs["fast"]
    run = api.store.load_run(rid)
    rows = _get(api, f"/runs/{rid}/aggregates")
    got = {(r["channel"], r["phase"]): r for r in rows}
    for ph in set(run.samples["phase"]):
        x = run.samples.loc[run.samples["phase"] == ph, "torque"].to_numpy(float)
        x = x[np.isfinite(x)]
        r = got[("torque", ph)]
        assert r["count"] == x.size
        assert r["mean"] == pytest.approx(x.mean(), rel=1e-9, abs=1e-9)
        assert r["var"] == pytest.approx(x.var(ddof=1), rel=1e-6)
        assert r["min"] == x.min() and r["max"] == x.max()
    whole = _get(api, f"/runs/{rid}/aggregates", by_phase=False)
    t = {r["channel"]: r for r in whole}["torque"]
    assert t["count"] == np.isfinite(run.samples["torque"].to_numpy(float)).sum()


def test_acceptance_indicators(api):
    from core.acceptance import acceptance

    rid = api.runs["fast"]
    d = _get(api, f"/runs/{rid}/acceptance")
    want = acceptance(api.store.load_run(rid))
    assert [i["name"] for i in d["indicators"]] == [i.name for i in want]
    assert [i["passed"] for i in d["indicators"]] == [i.passed for i in want]
    judged = [i.passed for i in want if i.passed is not None]
    assert judged and d["passed"] == all(judged)


def test_run_report_json_and_html_with_plots(api):
    rid = api.runs["fast"]
    rep = _get(api, f"/reports/runs/{rid}")
    assert rep["run"]["id"] == rid and rep["acceptance"] and rep["aggregates"]
    r = api.client.get(f"/reports/runs/{rid}/html", headers=api.h("viewer"))
    assert r.status_code == 200 and r.headers["content-type"].startswith("text/html")
    imgs = dict(re.findall(r'<img alt="([a-z_]+)" src="data:image/svg\+xml;base64,([^"]+)"', r.text))
    assert set(imgs) == {"following", "hysteresis", "current_vs_torque", "temperatures"}
    for svg in imgs.values():
        doc = base64.b64decode(svg)
        assert doc.lstrip().startswith(b"<?xml") and b"<svg" in doc and b"<path" in doc
    assert "Acceptance indicators" in r.text and "Per-phase aggregates" in r.text
    assert api.client.get("/reports/runs/99999/html", headers=api.h("viewer")).status_code == 404
