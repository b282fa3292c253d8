"""Property-based tests against the live OpenAPI schema (Schemathesis): generated requests to
every operation, with an admin token, get no 5xx and answers that match the schema (status
codes, content types, response bodies). Token revocation is left out: a generated id could
revoke the test's own token (tests/test_api_auth.py covers it)."""

from __future__ import annotations

import pytest

schemathesis = pytest.importorskip("schemathesis")
from hypothesis import HealthCheck, given, settings  # noqa: E402


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
    # the app's lifespan already runs (st_api's TestClient): the store is on app.state
    ops = [op for op in _operations(st_api.client.app) if op.method.upper() != "DELETE"]
    assert len(ops) >= 15
    headers = st_api.h("admin")
    for op in ops:
        @given(case=op.as_strategy())
        @settings(max_examples=25, deadline=None, suppress_health_check=list(HealthCheck),
                  database=None)
        def check(case):
            case.call_and_validate(headers=headers)
        check()
