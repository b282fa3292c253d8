"""The `diagnosis` job kind through HTTP: validation and roles; a diagnosis of a stored emulator
campaign with a withheld effect (gear ripple) run by a worker → succeeded → its report stored in
SQL (a 'diagnosis' JSON Report row of the nominal model's fit) and linked to the runs by role →
the verdict names the effect, equal to a direct estimator call → the job report's "Sim-to-real
gap" section with its SVG figures; restricted candidates (no final model); and the identification
job's predicted-vs-measured figure."""

from __future__ import annotations

import base64
import html
import re

import numpy as np
import pytest
from api_fixtures import api, drain, get  # noqa: F401  (api: fixture)
from diagnosis_fixtures import INJECTED, ORDER, diagnosis_body, store_campaign


@pytest.fixture(scope="module")
def campaign(api):
    """(train ids, test ids) of the stored campaign (once per database)."""
    pytest.importorskip("numba")
    return store_campaign(api.store)


def post(api, body, role="operator"):
    return api.client.post("/jobs", json=body, headers=api.h(role))


def svgs(html: str) -> dict[str, bytes]:
    return {k: base64.b64decode(v) for k, v in
            re.findall(r'<img alt="([a-z_0-9]+)" src="data:image/svg\+xml;base64,([^"]+)"', html)}


def svg_text(text: str) -> bytes:
    """A text as matplotlib writes it in its SVG comment (XML-escaped)."""
    return html.escape(text, quote=False).encode()


def test_diagnosis_submission_is_validated_and_needs_the_operator_role(api, campaign):
    train, test = campaign
    assert "diagnosis" in get(api, "/jobs/kinds")
    for bad in (diagnosis_body(train, []),
                {"kind": "diagnosis", "params": {"run_ids": train}},
                diagnosis_body(train, test, model="eq9"),           # not a linear nominal model
                diagnosis_body(train, test, effects=["not_an_effect"]),
                diagnosis_body(train, test, n_boot=10**6),
                diagnosis_body(train, test, rename=[{"old": "q; DROP", "new": "q"}]),
                diagnosis_body(train, test, surprise=1)):
        r = post(api, bad)
        assert r.status_code == 422, (bad, r.text)
    assert post(api, diagnosis_body(train, [99999])).status_code == 404
    assert post(api, diagnosis_body(train, test), role="viewer").status_code == 403
    assert api.client.post("/jobs", json=diagnosis_body(train, test)).status_code == 401
    assert get(api, "/jobs?kind=diagnosis") == []
    # a run in both roles passes the schema and fails when the job runs, with the reason
    jid = post(api, diagnosis_body(train, [train[0]])).json()["id"]
    drain(api)
    job = get(api, f"/jobs/{jid}")
    assert job["state"] == "failed" and "both training and held-out" in job["error"]
    assert job["result_ids"] == []


def test_diagnosis_job_names_the_withheld_effect_and_stores_its_report(api, campaign):
    from sqlalchemy import select

    from db.jobs import json_document
    from db.models import Report, ResultRun
    from estimator.diagnosis import DiagnosisOptions, diagnose_detailed

    train, test = campaign
    r = post(api, diagnosis_body(train, test))
    assert r.status_code == 202 and r.headers["location"] == f"/jobs/{r.json()['id']}"
    jid = r.json()["id"]
    drain(api)
    job = get(api, f"/jobs/{jid}")
    assert job["state"] == "succeeded", job["error"]
    results = get(api, f"/jobs/{jid}/results")
    # the nominal model's fit (with the report), the fit with the chosen effect, then the
    # twist–torque law's fits when the diagnosis covered that law
    assert [x["model"] for x in results][:2] == ["eq4", f"eq4+{INJECTED}"]
    roles = {(t, "train") for t in train} | {(t, "test") for t in test}
    assert all({(x["run_id"], x["role"]) for x in res["runs"]} == roles for res in results)
    doc = results[0]["documents"]["diagnosis"]
    assert all(x["documents"] == {} for x in results[1:])
    v = doc["verdict"]
    output_law = [c for c in doc["candidates"] if c.get("model", "eq4") == "eq4"]
    assert v["effects"][0] == INJECTED and output_law[0]["effect"] == INJECTED
    assert output_law[0]["significant"]
    assert v["rmse_test_after"] < 0.8 * doc["baseline"]["rmse_test"]
    assert doc["tests"]["angle_line"]["order"] == ORDER
    # the series the report's plots need: decimated, every run, the flagged regions' members
    s = doc["series"]
    assert sorted(set(s["run"])) == list(range(len(train) + len(test)))
    assert len(s["t"]) == len(s["measured"]) == len(s["baseline"]) == len(s["final"])
    assert [g["where"] for g in s["regions"]] == [g["where"] for g in doc["regions"]]
    e0 = np.subtract(s["measured"], s["baseline"])
    e1 = np.subtract(s["measured"], s["final"])
    assert np.sqrt(np.mean(e1 ** 2)) < 0.8 * np.sqrt(np.mean(e0 ** 2))
    # in SQL: one application/json Report row of kind 'diagnosis' on the nominal model's result
    with api.store.ReadSession() as sess:
        reps = sess.execute(select(Report.kind, Report.media_type, Report.result_id)
                            .where(Report.result_id.in_([x["id"] for x in results]))).all()
        links = sess.execute(select(ResultRun.run_id, ResultRun.role)
                             .where(ResultRun.result_id == results[0]["id"])).all()
    assert reps == [("diagnosis", "application/json", results[0]["id"])]
    assert set(links) == roles
    used = get(api, f"/runs/{test[0]}")["results"]
    assert {"result_id": results[0]["id"], "job_id": jid, "model": "eq4", "method": "ls",
            "role": "test"} in used
    # the same numbers as the estimator called directly on the stored runs
    direct = diagnose_detailed([api.store.load_run(i) for i in train],
                               [api.store.load_run(i) for i in test], "eq4",
                               options=DiagnosisOptions(series_points=400))
    assert v["effects"] == direct.report["verdict"]["effects"]
    assert v["status"] == direct.report["verdict"]["status"]
    fits = [direct.baseline, direct.final]
    tx = getattr(direct, "transmission", None)
    if tx is not None:
        fits += [f for f in (tx.baseline, tx.final) if f is not None]
    assert [x["model"] for x in results] == [f.model for f in fits]
    for res, f in zip(results, fits):
        np.testing.assert_allclose([p["mean"] for p in res["fit"]["params"]], f.mean, rtol=1e-9)
    assert doc["shrinkage"] == json_document(direct.report["shrinkage"])

    # the job report: JSON with the document, HTML with the section and its figures
    rep = get(api, f"/reports/jobs/{jid}")
    assert rep["diagnosis"]["verdict"] == v and rep["results"][0]["documents"] == ["diagnosis"]
    page = api.client.get(f"/reports/jobs/{jid}/html", headers=api.h("viewer")).text
    for text in ("Sim-to-real gap", f"Verdict: {v['status']} — {' + '.join(v['effects'])}</h3>",
                 "Where it lies: flagged regions", "Which effect: candidates",
                 "How the nominal parameters moved", "Before and after in the flagged regions"):
        assert text in page, text
    figs = svgs(page)
    names = {"diagnosis_residual_map", "diagnosis_residual_vs_angle",
             "diagnosis_residual_vs_time", "diagnosis_candidates"}
    assert names <= set(figs)
    regions = [n for n in figs if n.startswith("diagnosis_region_")]
    assert len(regions) == min(4, len(doc["regions"])) > 0
    assert all(b"<svg" in figs[n] and b"<path" in figs[n] for n in names | set(regions))
    # matplotlib writes each text as an SVG comment: the figures say what they show
    assert f"2π/{ORDER}".encode() in figs["diagnosis_residual_vs_angle"]
    assert f"with {INJECTED}".encode() in figs["diagnosis_region_1"]
    assert svg_text(doc["regions"][0]["where"]) in figs["diagnosis_region_1"]
    for r in doc["all_regions"]:
        assert svg_text(r["where"]) in figs["diagnosis_residual_map"], r["where"]


def test_restricted_candidates_leave_the_gap_unexplained_with_no_final_model(api, campaign):
    train, test = campaign
    jid = post(api, diagnosis_body(train, test, effects=["torque_offset", "time_delay"],
                                   n_boot=100)).json()["id"]
    drain(api)
    job = get(api, f"/jobs/{jid}")
    assert job["state"] == "succeeded", job["error"]
    results = get(api, f"/jobs/{jid}/results")
    assert results[0]["model"] == "eq4"
    assert not any(x["model"].startswith("eq4+") for x in results)     # no effect chosen
    doc = results[0]["documents"]["diagnosis"]
    assert {c["effect"] for c in doc["candidates"]} <= {"torque_offset", "time_delay"}
    assert doc["verdict"]["status"] == "unexplained" and doc["verdict"]["effects"] == []
    assert doc["regions"], "an unexplained gap must still say where it lies"
    page = api.client.get(f"/reports/jobs/{jid}/html", headers=api.h("viewer")).text
    assert "Verdict: unexplained</h3>" in page
    assert "diagnosis_residual_map" in svgs(page)


def test_identification_report_has_predicted_vs_measured(api, campaign):
    train, test = campaign
    jid = post(api, {"kind": "identification",
                     "params": {"run_ids": train[:2], "test_run_ids": test[:1], "model": "eq4",
                                "method": "ls"}}).json()["id"]
    drain(api)
    res = get(api, f"/jobs/{jid}/results")[0]
    s = res["fit"]["extra"]["series"]
    assert set(s["run_id"]) == set(train[:2]) | {test[0]}
    assert {r for i, r in zip(s["run_id"], s["role"]) if i == test[0]} == {"test"}
    e = np.subtract(s["measured"], s["predicted"])
    tr = np.array(s["role"]) == "train"
    # the stored series is the fit replayed: its RMSE is the fit's, on a decimated subset
    assert np.sqrt(np.mean(e[tr] ** 2)) == pytest.approx(res["fit"]["rmse_train"], rel=0.15)
    assert np.sqrt(np.mean(e[~tr] ** 2)) == pytest.approx(res["fit"]["rmse_test"], rel=0.15)
    page = api.client.get(f"/reports/jobs/{jid}/html", headers=api.h("viewer")).text
    fig = svgs(page)["predicted_vs_measured"]
    assert b"Predicted vs measured" in fig and b"<path" in fig


EMPS = "/work/shared/data/emps"


def test_diagnosis_job_on_imported_emps_records_with_renamed_channels(api):
    """Imported real records of another rig (the EMPS benchmark, a prismatic drive): the job
    renames its channels onto the joint's (qm → q, force → torque) and diagnoses the EMPS
    nominal model, estimation record for training, validation record held out."""
    from pathlib import Path

    from core.emps import load_emps
    files = [Path(EMPS) / "DATA_EMPS.mat", Path(EMPS) / "DATA_EMPS_PULSES.mat"]
    if not all(f.exists() for f in files):
        pytest.skip(f"the EMPS records are not in {EMPS}")
    train, test = (api.store.save_run(load_emps(f), exit_status="success") for f in files)
    rename = [{"old": "qm", "new": "q"}, {"old": "force", "new": "torque"}]
    jid = post(api, diagnosis_body([train], [test], model="emps", rename=rename,
                                   cutoff_hz=100.0, decimate=10, n_boot=100)).json()["id"]
    drain(api)
    job = get(api, f"/jobs/{jid}")
    assert job["state"] == "succeeded", job["error"]
    res = get(api, f"/jobs/{jid}/results")[0]
    doc = res["documents"]["diagnosis"]
    assert res["model"] == "emps" and doc["baseline"]["model"] == "emps"
    assert [p["name"] for p in res["fit"]["params"]] == ["M", "Fv", "Fc", "offset"]
    assert doc["baseline"]["target"]["unit"] == "N"
    assert doc["verdict"]["status"] in ("explained", "none", "partly_explained", "unexplained")
    page = api.client.get(f"/reports/jobs/{jid}/html", headers=api.h("viewer")).text
    assert "Sim-to-real gap" in page and "diagnosis_residual_map" in svgs(page)
