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


def test_channel_data_time_range_and_decimation(api):
    rid = api.runs["fast"]
    arr = api.store.load_arrays(rid, ["t", "torque", "phase"])
    d = _get(api, f"/runs/{rid}/data", channels="torque,phase", t_start=10.0, t_end=20.0, every=3)
    sel = np.flatnonzero((arr["t"] >= 10.0) & (arr["t"] <= 20.0))[::3]
    assert set(d["channels"]) == {"t", "torque", "phase"}
    assert d["n"] == sel.size and d["every"] == 3
    np.testing.assert_array_equal(d["channels"]["t"], arr["t"][sel])
    np.testing.assert_allclose(d["channels"]["torque"], arr["torque"][sel])
    assert d["channels"]["phase"] == list(arr["phase"][sel])
    d = _get(api, f"/runs/{rid}/data", channels="q", max_points=100)   # decimated to the cap
    assert d["n"] <= 100 and d["every"] == int(np.ceil(arr["t"].size / 100))
    r = api.client.get(f"/runs/{rid}/data", params={"channels": "nope"}, headers=api.h("viewer"))
    assert r.status_code == 404 and "nope" in r.json()["detail"]


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
