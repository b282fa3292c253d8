"""A run's limit set (core.schemes.LIMIT_SETS) is chosen wherever a scheme is started (issue 13):
`rig run scheme1 --limit-set range`, `rig run --spec FILE` (params.limit_set) and the API's
POST /schemes/{1,2}/runs (params.limit_set, its values in the OpenAPI schema); the run records
it. Refused values: a one-line usage error with exit 2, or 422 with nothing started. Scheme 3
(no load) has no limit set to choose."""

from __future__ import annotations

import argparse
import json

import pytest
from test_api_schemes import SHORT, api, body, get, start, wait  # noqa: F401 (fixture)

RANGE = {**SHORT, "motor_speed_rpm": 300.0, "load_target": 180e3, "ramp_rate": 60e3,
         "limit_set": "range"}
"""Scheme 1 loading to 180 kN·m under the "range" limit set (~8 s of rig time)."""


def parse(argv: list[str]) -> argparse.Namespace:
    from commands import cmd_run
    parser = argparse.ArgumentParser(prog="rig run")
    cmd_run.add_arguments(parser)
    return parser.parse_args(argv)


def test_the_cli_option_chooses_the_limit_set_of_the_plan():
    from commands.cmd_run import run_spec
    from daq.plans import Plan

    spec = run_spec(parse(["scheme1", "--limit-set", "range", "--speed", "300",
                           "--load", "180000"]))
    assert spec.params == {"limit_set": "range", "motor_speed_rpm": 300.0,
                           "load_target": 180e3}
    plan = Plan.of(spec.scheme, **spec.params)
    assert plan.limits.name == "range" and plan.limits.torque_limit == 189e3
    assert plan.meta()["plan"]["limit_set"] == "range"
    assert Plan.of(2, **run_spec(parse(["scheme2", "--limit-set", "default"])).params
                   ).limits.name == "default"
    assert Plan.of(1, **run_spec(parse(["scheme1"])).params).limits.name == "default"


def test_the_spec_document_chooses_the_limit_set(tmp_path):
    from commands.cmd_run import run_spec

    f = tmp_path / "run.json"
    f.write_text(json.dumps({"scheme": 1, "params": {"limit_set": "range",
                                                     "motor_speed_rpm": 300.0,
                                                     "load_target": 180e3}}))
    spec = run_spec(parse(["--spec", str(f)]))
    assert spec.make_scheme().limit_set == "range"


@pytest.mark.parametrize("argv,says", [
    (["scheme1", "--limit-set", "bogus"], "limit_set"),
    (["scheme1", "--limit-set", ""], "limit_set"),
    (["scheme3", "--limit-set", "range"], "--limit-set does not apply to scheme 3"),
    (["scheme1", "--speed", "300", "--load", "180000"], "'default' limit set"),
    (["scheme1", "--limit-set", "default", "--speed", "300", "--load", "180000"],
     "'default' limit set"),
])
def test_a_refused_limit_set_is_a_one_line_usage_error(argv, says, capsys):
    from commands.cli import main

    assert main(["run", *argv]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and err[0].startswith("rig run: ") and says in err[0], err
    if "bogus" in argv:
        assert "default, range" in err[0]


def test_a_refused_limit_set_in_a_spec_is_exit_2(tmp_path, capsys):
    from commands.cli import main

    f = tmp_path / "run.json"
    f.write_text(json.dumps({"scheme": 2, "params": {"limit_set": "huge"}}))
    assert main(["run", "--spec", str(f)]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "limit_set" in err[0] and "default, range" in err[0], err


def test_the_api_schema_lists_the_limit_sets(api):  # noqa: F811
    from core.schemes import LIMIT_SETS

    schemas = api.client.get("/openapi.json").json()["components"]["schemas"]
    for n in (1, 2):
        s = schemas[f"Scheme{n}Params"]["properties"]["limit_set"]
        assert s["enum"] == list(LIMIT_SETS) and s["default"] == "default"
    assert "limit_set" not in schemas["Scheme3Params"]["properties"]


def test_the_api_refuses_a_limit_set_it_does_not_know_and_starts_nothing(api):  # noqa: F811
    before = get(api, "/acquisitions")
    for scheme, params in ((1, {**SHORT, "limit_set": "bogus"}),
                           (2, {"limit_set": 3}),
                           (3, {"limit_set": "range"}),
                           (1, {**RANGE, "limit_set": "default"})):
        r = api.client.post(f"/schemes/{scheme}/runs", json=body(params),
                            headers=api.h("operator"))
        assert r.status_code == 422 and ("limit_set" in r.text or "limit set" in r.text), r.text
    assert get(api, "/acquisitions") == before


def test_a_range_run_started_through_the_api_records_its_limit_set(api):  # noqa: F811
    loc = start(api, RANGE)
    end = wait(api, loc, lambda a: a["state"] == "ended", timeout=120.0)
    assert end["run_status"] == "success", end
    meta = get(api, f"/runs/{end['run_id']}")["meta"]
    assert meta["limits"]["limit_set"] == "range" and meta["limits"]["torque_limit"] == 189e3
    assert meta["scheme_params"]["limit_set"] == "range"
    assert meta["scheme_params"]["load_target"] == 180e3
