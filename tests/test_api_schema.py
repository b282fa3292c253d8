"""Property-based tests against the live OpenAPI schema (Schemathesis): generated requests to
every operation, with an admin token, get no 5xx and answers that match the schema (status
codes, content types, response bodies). Token revocation is left out: a generated id could
revoke the test's own token (tests/test_api_auth.py covers it).

Two kinds of operation judge a schema-valid body against facts a JSON schema cannot state (a
scheme that would turn the joint past its travel limit or ask a sample rate the PLC poll cannot
deliver; a job whose run is both a training and a held-out run): they answer 422 with the reason,
so Schemathesis's "schema-valid request accepted" check is left out for them alone
(tests/test_api_schemes.py and tests/test_api_diagnosis.py test those refusals)."""

from __future__ import annotations

import pytest

schemathesis = pytest.importorskip("schemathesis")
from hypothesis import HealthCheck, given, settings  # noqa: E402
from schemathesis.specs.openapi.checks import positive_data_acceptance  # noqa: E402

SEMANTIC_422 = ("/schemes/1/runs", "/schemes/2/runs", "/schemes/3/runs", "/jobs")
"""POST paths that refuse some schema-valid bodies with 422 and a reason (see the docstring)."""


@pytest.fixture(scope="module")
def st_api(tmp_path_factory):
    from api_fixtures import _api, database
    with database("sqlite", tmp_path_factory) as url:
        yield from _api(url)


def _operations(app):
    schema = schemathesis.openapi.from_asgi("/openapi.json", app)
    return [r.ok() for r in schema.get_all_operations()]


@pytest.mark.slow
def test_no_server_error_and_answers_match_the_schema(st_api):
    # the app's lifespan already runs (st_api's TestClient): the store is on app.state.
    # POST /schemes/{n}/runs are fuzzed too: a schema-valid body may start a real acquisition
    # (stand-in + `rig run` processes; one per target, the others answer 409), stopped when the
    # app shuts down. They were left out once: the fuzz drew scheme 2's step = 5e-324 N·m and the
    # profile's loop grew without end in this process (past 16 GB); the step is bounded now
    # (core.schemes.MIN_LOAD_STEP, tests/test_scheme_step_bound.py).
    ops = [op for op in _operations(st_api.client.app) if op.method.upper() != "DELETE"]
    assert len(ops) >= 18
    assert {"/schemes/1/runs", "/schemes/2/runs", "/schemes/3/runs"} <= {
        op.path for op in ops if op.method.upper() == "POST"}
    headers = st_api.h("admin")
    for op in ops:
        @given(case=op.as_strategy())
        @settings(max_examples=25, deadline=None, suppress_health_check=list(HealthCheck),
                  database=None)
        def check(case):
            semantic = case.operation.method.upper() == "POST" and case.operation.path in SEMANTIC_422
            case.call_and_validate(headers=headers,
                                   excluded_checks=[positive_data_acceptance] if semantic else None)
        check()
