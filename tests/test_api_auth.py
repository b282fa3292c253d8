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


# --- token expiry, token listing pages, Idempotency-Key per token ------------------------------

def test_expired_token_is_refused_with_401(api):
    from datetime import timedelta

    from sqlalchemy import update

    from db.models import ApiToken, utcnow

    r = api.client.post("/tokens", json={"name": "short", "role": "viewer", "expires_in_s": 3600},
                        headers=api.h("admin"))
    assert r.status_code == 201
    secret, tid = r.json()["token"], r.json()["id"]
    h = {"Authorization": f"Bearer {secret}"}
    assert api.client.get("/runs", headers=h).status_code == 200           # not yet expired
    with api.store.Session.begin() as s:                                    # an hour goes by
        s.execute(update(ApiToken).where(ApiToken.id == tid)
                  .values(expires_at=utcnow() - timedelta(seconds=1)))
    r = api.client.get("/runs", headers=h)
    assert r.status_code == 401 and r.headers.get("www-authenticate") == "Bearer"
    for bad in (0, -5, 1e12, "soon"):
        r = api.client.post("/tokens", json={"name": "x", "role": "viewer", "expires_in_s": bad},
                            headers=api.h("admin"))
        assert r.status_code == 422, bad
    forever = api.client.post("/tokens", json={"name": "forever", "role": "viewer"},
                              headers=api.h("admin")).json()
    assert forever["expires_at"] is None
    listing = {t["id"]: t for t in api.client.get("/tokens", params={"limit": 1000},
                                                   headers=api.h("admin")).json()}
    assert listing[tid]["expires_at"] is not None and listing[forever["id"]]["expires_at"] is None


def test_cli_token_create_with_expiry(api, capsys):
    from commands.cli import main

    from db.tokens import verify_token

    assert main(["token", "create", "--role", "viewer", "--expires-in", "7d",
                 "--db", api.url]) == 0
    secret = capsys.readouterr().out.strip()
    row = verify_token(api.store, secret)
    assert row is not None and row.expires_at is not None
    assert main(["token", "create", "--role", "viewer", "--expires-in", "nan",
                 "--db", api.url]) == 2
    assert "--expires-in" in capsys.readouterr().err
    assert main(["token", "list", "--db", api.url]) == 0
    assert "expires" in capsys.readouterr().out


def test_token_listing_is_paged_with_the_total(api):
    for k in range(3):
        api.client.post("/tokens", json={"name": f"page-{k}", "role": "viewer"},
                        headers=api.h("admin"))
    whole = api.client.get("/tokens", params={"limit": 1000}, headers=api.h("admin"))
    total = int(whole.headers["x-total-count"])
    assert total == len(whole.json()) >= 6
    ids = [t["id"] for t in whole.json()]
    assert ids == sorted(ids)
    page = api.client.get("/tokens", params={"limit": 2, "offset": 1}, headers=api.h("admin"))
    assert [t["id"] for t in page.json()] == ids[1:3]
    assert int(page.headers["x-total-count"]) == total
    assert api.client.get("/tokens", params={"limit": 0},
                          headers=api.h("admin")).status_code == 422


def test_idempotency_key_belongs_to_the_token(api):
    from db.tokens import create_token

    other = {"Authorization": f"Bearer {create_token(api.store, 'ops-2', ['operator'])}"}
    mine = api.h("operator")
    body = _job_body(api)
    key = {"Idempotency-Key": "shared-key-1"}
    a1 = api.client.post("/jobs", json=body, headers={**mine, **key})
    a2 = api.client.post("/jobs", json=body, headers={**mine, **key})
    b1 = api.client.post("/jobs", json=body, headers={**other, **key})
    b2 = api.client.post("/jobs", json=body, headers={**other, **key})
    assert (a1.status_code, a2.status_code, b1.status_code, b2.status_code) == (202, 200, 202, 200)
    assert a1.json()["id"] == a2.json()["id"]                      # same token: same job back
    assert b1.json()["id"] == b2.json()["id"] != a1.json()["id"]   # other token: its own job
    # another token's key neither conflicts with nor reveals the first token's job
    body2 = {**body, "params": {**body["params"], "method": "exact"}}
    c = api.client.post("/jobs", json=body2, headers={**other, "Idempotency-Key": "mine-only"})
    assert c.status_code == 202
    assert api.client.post("/jobs", json=body,
                           headers={**mine, "Idempotency-Key": "mine-only"}).status_code == 202
    r = api.client.post("/jobs", json=body2, headers={**mine, **key})
    assert r.status_code == 409 and "shared-key-1" in r.json()["detail"]
