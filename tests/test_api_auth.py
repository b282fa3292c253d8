"""Every endpoint through HTTP: 401 without a valid token, 403 with too low a role, the right
role passes; tokens are stored hashed, revocation works, request bodies have a size limit."""

from __future__ import annotations

import pytest
from api_fixtures import api  # noqa: F401  (fixture)

# (method, path, least role); {run}/{job} filled in by the test
ENDPOINTS = [
    ("GET", "/runs", "viewer"),
    ("GET", "/runs/{run}", "viewer"),
    ("GET", "/runs/{run}/data?channels=q&max_points=10", "viewer"),
    ("GET", "/runs/{run}/aggregates", "viewer"),
    ("GET", "/runs/{run}/acceptance", "viewer"),
    ("GET", "/jobs", "viewer"),
    ("GET", "/jobs/kinds", "viewer"),
    ("GET", "/jobs/{job}", "viewer"),
    ("GET", "/jobs/{job}/results", "viewer"),
    ("GET", "/reports/runs/{run}", "viewer"),
    ("GET", "/reports/jobs/{job}", "viewer"),
    ("GET", "/reports/jobs/{job}/html", "viewer"),
    ("POST", "/jobs", "operator"),
    ("POST", "/jobs/{job}/cancel", "operator"),
    ("GET", "/tokens", "admin"),
    ("POST", "/tokens", "admin"),
]
ROLES = ("viewer", "operator", "admin")


def _job_body(api):
    return {"kind": "identification",
            "params": {"run_ids": [api.runs["fast"]], "model": "eq4", "method": "ls"}}


def _call(api, method, path, role, job_id):
    p = path.format(run=api.runs["fast"], job=job_id)
    body = None
    if method == "POST" and p == "/jobs":
        body = _job_body(api)
    elif method == "POST" and p == "/tokens":
        body = {"name": "made-by-test", "role": "viewer"}
    headers = api.h(role) if role in ROLES else (
        {"Authorization": "Bearer not-a-token"} if role == "bad" else {})
    return api.client.request(method, p, json=body, headers=headers)


@pytest.fixture(scope="module")
def job_id(api):
    r = api.client.post("/jobs", json=_job_body(api), headers=api.h("operator"))
    assert r.status_code == 202
    return r.json()["id"]


@pytest.mark.parametrize("method,path,need", ENDPOINTS)
def test_every_endpoint_needs_a_token_and_its_role(api, job_id, method, path, need):
    for who in (None, "bad"):
        r = _call(api, method, path, who, job_id)
        assert r.status_code == 401, (who, r.text)
        assert r.headers.get("www-authenticate") == "Bearer"
    for role in ROLES:
        r = _call(api, method, path, role, job_id)
        if ROLES.index(role) < ROLES.index(need):
            assert r.status_code == 403, (role, r.text)
        else:
            assert r.status_code in (200, 201, 202), (role, r.status_code, r.text)


def test_run_report_html_and_delete_token_roles(api):
    # the heaviest page and the DELETE route, once each per role
    rid = api.runs["fast"]
    assert api.client.get(f"/reports/runs/{rid}/html").status_code == 401
    assert api.client.get(f"/reports/runs/{rid}/html", headers=api.h("viewer")).status_code == 200
    new = api.client.post("/tokens", json={"name": "x", "role": "viewer"}, headers=api.h("admin"))
    tid = new.json()["id"]
    assert api.client.delete(f"/tokens/{tid}").status_code == 401
    assert api.client.delete(f"/tokens/{tid}", headers=api.h("operator")).status_code == 403
    assert api.client.delete(f"/tokens/{tid}", headers=api.h("admin")).status_code == 204
    assert api.client.delete(f"/tokens/{tid}", headers=api.h("admin")).status_code == 404


def test_created_token_works_is_stored_hashed_and_revocation_locks_it_out(api):
    from sqlalchemy import select

    from db.models import ApiToken
    from db.tokens import hash_token

    r = api.client.post("/tokens", json={"name": "ops", "role": "operator"},
                        headers=api.h("admin"))
    assert r.status_code == 201
    secret, tid = r.json()["token"], r.json()["id"]
    h = {"Authorization": f"Bearer {secret}"}
    assert api.client.get("/runs", headers=h).status_code == 200
    assert api.client.get("/tokens", headers=h).status_code == 403          # operator < admin
    listing = api.client.get("/tokens", headers=api.h("admin")).text
    assert secret not in listing
    with api.store.ReadSession() as s:
        row = s.get(ApiToken, tid)
        assert row.token_hash == hash_token(secret) and row.scopes == ["operator"]
        stored = " ".join(str(v) for t in s.execute(select(ApiToken)).scalars()
                          for v in (t.name, t.token_hash, t.prefix, t.scopes))
    assert secret not in stored
    assert api.client.delete(f"/tokens/{tid}", headers=api.h("admin")).status_code == 204
    assert api.client.get("/runs", headers=h).status_code == 401


def test_token_without_a_role_is_refused(api):
    from db.tokens import create_token
    secret = create_token(api.store, "no-role", [])
    r = api.client.get("/runs", headers={"Authorization": f"Bearer {secret}"})
    assert r.status_code == 401


def test_request_body_size_limit(api):
    big = {"kind": "identification",
           "params": {"run_ids": [api.runs["fast"]], "model": "eq4", "method": "ls",
                      "pad": "x" * 70_000}}
    r = api.client.post("/jobs", json=big, headers=api.h("operator"))
    assert r.status_code == 413

    def chunks():                       # no Content-Length: counted while read
        for _ in range(20):
            yield b"x" * 8192
    r = api.client.post("/jobs", content=chunks(), headers=api.h("operator"))
    assert r.status_code == 413


def test_openapi_docs_are_served(api):
    assert api.client.get("/openapi.json").status_code == 200
    assert api.client.get("/docs").status_code == 200


def test_cli_token_create_prints_a_working_token(api, capsys):
    from commands.cli import main

    assert main(["token", "create", "--role", "viewer", "--name", "cli-test",
                 "--db", api.url]) == 0
    secret = capsys.readouterr().out.strip()
    h = {"Authorization": f"Bearer {secret}"}
    assert api.client.get("/runs", headers=h).status_code == 200
    assert api.client.post("/jobs", json=_job_body(api), headers=h).status_code == 403


def test_settings_come_from_rig_environment(monkeypatch):
    from api.settings import Settings

    monkeypatch.setenv("RIG_DB_URL", "sqlite:////tmp/x/rig.sqlite")
    monkeypatch.setenv("RIG_API_PORT", "8123")
    monkeypatch.setenv("RIG_WORKERS", "3")
    monkeypatch.setenv("RIG_MAX_BODY_BYTES", "2048")
    st = Settings.from_env()
    assert (st.db_url, st.port, st.workers, st.max_body_bytes, st.host) == \
        ("sqlite:////tmp/x/rig.sqlite", 8123, 3, 2048, "127.0.0.1")
    assert Settings.from_env(port=9000, workers=None).port == 9000
    assert Settings.from_env(port=9000, workers=None).workers == 3
