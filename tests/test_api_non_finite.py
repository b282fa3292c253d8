"""NaN, Infinity and -Infinity in JSON request bodies (Python's json reads these literals, JSON has
no such numbers): every POST/PUT endpoint with a numeric field answers 422 naming the field,
never 500 (a validation error holding a NaN cannot be rendered as JSON; an Infinity passes a
one-sided bound), and nothing is created: no acquisition, job, token or rig model (issue 13)."""

from __future__ import annotations

import pytest
from sqlalchemy import func, select

LITERALS = ("NaN", "Infinity", "-Infinity")

SCHEME = '{"target":"emulator","operator":"alice",%s}'
CASES = [
    # (method, path, body with @ where the literal goes, the field's dotted name)
    ("post", "/schemes/1/runs", SCHEME % '"params":{"ramp_rate":@}', "params.ramp_rate"),
    ("post", "/schemes/2/runs", SCHEME % '"params":{"step":@}', "params.step"),
    ("post", "/schemes/3/runs", SCHEME % '"params":{"a_max":@}', "params.a_max"),
    ("post", "/schemes/1/runs", SCHEME % '"emulator":{"time_scale":@}', "emulator.time_scale"),
    ("post", "/schemes/1/runs", SCHEME % '"emulator":{"effects":{"time_delay":{"delay":@}}}',
     "emulator.effects.time_delay.delay"),
    ("post", "/jobs", '{"kind":"identification","params":{"run_ids":[1],"model":"eq4",'
                      '"method":"ls","options":{"level":@}}}', "params.options.level"),
    ("post", "/jobs", '{"kind":"sensitivity","params":{"run_ids":[1],"n_base":@}}',
     "params.n_base"),
    ("post", "/jobs", '{"kind":"diagnosis","params":{"run_ids":[1],"test_run_ids":[2],'
                      '"z_gain":@}}', "params.z_gain"),
    ("post", "/jobs", '{"kind":"reproduction","params":{"seed":@}}', "params.seed"),
    ("post", "/tokens", '{"name":"x","role":"viewer","expires_in_s":@}', "expires_in_s"),
    ("put", "/rig-model", '{"fit_id":@}', "fit_id"),
]


@pytest.fixture(scope="module")
def nf_api(tmp_path_factory):
    from api_fixtures import _api, database
    with database("sqlite", tmp_path_factory) as url:
        yield from _api(url)


def _counts(api) -> tuple[int, int, int, int]:
    from db.models import ApiToken, Job, RigModel
    with api.store.ReadSession() as s:
        n = tuple(s.execute(select(func.count()).select_from(m)).scalar_one()
                  for m in (Job, ApiToken, RigModel))
    acqs = api.client.get("/acquisitions", headers=api.h("viewer"))
    assert acqs.status_code == 200, acqs.text
    return (*n, len(acqs.json()))


def test_the_cases_cover_every_post_and_put_with_a_numeric_field(nf_api):
    """A new endpoint with a number in its body must join CASES."""
    schema = nf_api.client.get("/openapi.json").json()
    comps = schema["components"]["schemas"]

    def numeric(node, seen=()) -> bool:
        if isinstance(node, dict):
            if node.get("type") in ("number", "integer"):
                return True
            ref = node.get("$ref")
            if ref and ref not in seen:
                return numeric(comps[ref.rsplit("/", 1)[1]], (*seen, ref))
            return any(numeric(v, seen) for v in node.values())
        if isinstance(node, list):
            return any(numeric(v, seen) for v in node)
        return False

    want = {(m, p) for p, ops in schema["paths"].items() for m, op in ops.items()
            if m in ("post", "put", "patch") and numeric(op.get("requestBody", {}))}
    assert want == {(m, p) for m, p, _, _ in CASES}


@pytest.mark.parametrize("literal", LITERALS)
@pytest.mark.parametrize("method,path,template,field", CASES,
                         ids=[f"{m} {p} {f}" for m, p, _, f in CASES])
def test_non_finite_number_is_422_naming_the_field(nf_api, method, path, template, field,
                                                    literal):
    before = _counts(nf_api)
    r = getattr(nf_api.client, method)(
        path, content=template.replace("@", literal),
        headers={**nf_api.h("admin"), "Content-Type": "application/json"})
    assert r.status_code == 422, r.text
    detail = r.json()["detail"]
    assert any(field in d["msg"] and literal in d["msg"] for d in detail), detail
    assert ["body", *field.split(".")] in [d["loc"] for d in detail]
    assert _counts(nf_api) == before


def test_a_string_holding_nan_is_no_number(nf_api):
    """Only the number literals are refused: a text saying NaN is judged by its field."""
    r = nf_api.client.post("/tokens", json={"name": "NaN Infinity", "role": "viewer"},
                           headers=nf_api.h("admin"))
    assert r.status_code == 201, r.text


def test_a_nan_query_parameter_is_422_not_500(nf_api):
    r = nf_api.client.get("/runs", params={"speed": "nan"}, headers=nf_api.h("viewer"))
    assert r.status_code == 422, r.text
