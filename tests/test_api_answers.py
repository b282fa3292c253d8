"""The service's answer models (api/answers.py): the OpenAPI schema names what every JSON route
of the runs, jobs, tokens and reports routers returns; an answer passed through its model is
the same bytes as the answer built (no key dropped, reordered or retyped); a key an answer
gains where it is built reaches the client."""

from __future__ import annotations

from typing import Any

import pytest
from pydantic import TypeAdapter

from api import answers

ROUTERS = ("/runs", "/jobs", "/tokens", "/reports")


@pytest.fixture(scope="module")
def sq_api(tmp_path_factory):
    from api_fixtures import _api, database
    with database("sqlite", tmp_path_factory) as url:
        yield from _api(url)


def _named(schema: dict[str, Any]) -> bool:
    """True for a schema that is (a list or map of) a named component."""
    if "$ref" in schema:
        return True
    if schema.get("type") == "array":
        return _named(schema.get("items", {}))
    if schema.get("type") == "object" and isinstance(schema.get("additionalProperties"), dict):
        return _named(schema["additionalProperties"])
    return False


def test_every_json_answer_has_a_named_schema(sq_api):
    spec = sq_api.client.get("/openapi.json").json()
    checked = []
    for path, ops in spec["paths"].items():
        if not path.startswith(ROUTERS):
            continue
        for method, op in ops.items():
            for code, resp in op["responses"].items():
                if not code.startswith("2") or "application/json" not in resp.get("content", {}):
                    continue
                schema = resp["content"]["application/json"]["schema"]
                assert _named(schema), f"{method.upper()} {path} {code}: {schema}"
                checked.append((method, path))
    assert len(checked) >= 14, checked
    run = spec["components"]["schemas"]["RunDetail"]
    assert {"id", "status", "meta", "channels", "interruptions", "results"} \
        <= set(run["properties"])


def _same_bytes(model, value: Any) -> None:
    """`value` through `model` serialises to the bytes FastAPI sends for the bare value."""
    ta = TypeAdapter(model)
    assert ta.dump_json(ta.validate_python(value)) == TypeAdapter(Any).dump_json(value)


def test_answers_through_their_models_are_the_bytes_built(sq_api):
    from api.reports import run_report
    from api.routers.runs import _summary
    from db import jobs as queue
    from db.models import Rig, Run
    from sqlalchemy import select

    store, rid = sq_api.store, sq_api.runs["fast"]
    with store.ReadSession() as s:
        rows = s.execute(select(Run, Rig.name).outerjoin(Rig, Rig.id == Run.rig_id)).all()
        summaries = [_summary(r, name) for r, name in rows]
    assert any(isinstance(x["motor_speed_rpm"], int) for x in summaries)   # 3000, not 3000.0
    _same_bytes(list[answers.RunSummary], summaries)
    _same_bytes(answers.RunInfo, store.run_info(rid))
    _same_bytes(list[answers.RunChannel], store.channels(rid))
    _same_bytes(answers.RunReport, run_report(store, rid, with_plots=False))
    job, _ = queue.submit(store, "identification", {"run_ids": [rid], "model": "eq4",
                                                    "method": "ls"})
    _same_bytes(answers.JobInfo, job)
    _same_bytes(answers.JobInfo, queue.cancel(store, job["id"]))


def test_a_key_added_where_an_answer_is_built_reaches_the_client(sq_api, monkeypatch):
    from db.store import Store

    run_info = Store.run_info
    monkeypatch.setattr(Store, "run_info",
                        lambda self, run_id: {**run_info(self, run_id), "new_fact": [1, 2.5]})
    r = sq_api.client.get(f"/runs/{sq_api.runs['fast']}", headers=sq_api.h("viewer"))
    assert r.status_code == 200, r.text
    assert r.json()["new_fact"] == [1, 2.5]
